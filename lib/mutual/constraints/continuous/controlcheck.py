"""Recorded controls against the recorded motion (:func:`check_control_motion`): a unit, a sign, exchanged
columns, a shift by one row or zeros for missing values, in the whole file or in the demonstrations that stand
out. Distances are in cell widths (:mod:`.misses`)."""

from typing import NamedTuple

import numpy as np

from ...inputs import warn
from .misses import difference, mean_miss, per_demonstration, recorded_steps, spread


def check_control_motion(problem, recording, states, controls, most=4000):
    """Warn when the recorded controls do not explain the recorded motion: one step is close to linear in the
    control, so the map M (m x m) and offset c for which steps under M u + c best explain the motion are fitted
    by least squares (and the usual mistakes of :func:`_candidates` are tried as they are, for steps far from linear
    in the control; and steps under the control one step of dt earlier or later); when one of them
    cuts the mean squared miss of the next states to a quarter of what the controls as recorded give (clipped to
    the set's range, as the models take them), and the miss is more than a fiftieth of a cell, what changed is
    named: a factor per control, exchanged columns, an offset, or the shift. Every recorded control 0 while the
    motion needs others is said apart (missing values written as 0?). The whole file is fitted on up to ``most``
    steps of demonstrations spread over it. When it passes, every demonstration is scored under its recorded
    controls, and those that stand out are named where a unit, a sign, exchanged columns, a shift or zeros explain
    them (:func:`_odd_groups`); a fit needs 4 (m^2 + m) recorded steps, so a single shorter demonstration is not
    fitted alone. Dynamics that fail on a control the check tries leave it unsaid (the model's own steps report
    such a failure)."""
    demos = spread(len(states), most // max(states.shape[1], 1))
    names = problem.system.control_names
    where = f"column {names[0]!r}" if len(names) == 1 else "columns " + ", ".join(map(repr, names))
    try:
        found = _control_motion(problem, states[demos], controls[demos])
        groups = [] if found else _odd_groups(problem, states, controls)
    except ValueError:
        return
    if found:
        warn(f"{recording.source}, {where}: {found.text}")
    for group, found in groups:
        ids = ", ".join(repr(recording.ids[d]) for d in group[:5]) + (", ..." if len(group) > 5 else "")
        units = "; were they recorded in other units?" if found.kind == "mapped" and _scaled(found.M) else ""
        warn(f"{recording.source}, {where}: demonstrations {ids} ({len(group)} of {len(states)}) follow their recorded "
             f"controls far worse than the others do: {found.text}{units}")


def _odd(problem, states, controls):
    """The demonstrations that stand out, worst first: the mean squared miss of their steps under their recorded
    controls is above 4 times that of the demonstration at the 5th percentile of those that move (one that sits
    still or a few lucky ones set no standard) and above a fiftieth of a cell."""
    miss = per_demonstration(problem, states, controls)
    moves = np.isfinite(miss) & (np.ptp(states, axis=1).max(axis=1) > 0)
    if not moves.any():
        return np.zeros(0, int)
    typical = np.percentile(miss[moves], 5)
    odd = np.flatnonzero((miss > 4 * typical) & (miss > 0.02 ** 2))
    return odd[np.argsort(-miss[odd], kind="stable")]


def _odd_groups(problem, states, controls, alone=20, most=4000):
    """``[(demonstrations, found)]``: the demonstrations that stand out (:func:`_odd`) and what explains them where
    it is a change of unit, sign or columns, a shift or zeros (an offset or a mild factor is also what an
    unmodelled force or a weaker actuator gives). The changes: fitted to them together (on up to ``most`` steps)
    and to the worst ``alone`` each alone (:func:`_control_motion`), then the :func:`_candidates` as they are (a
    demonstration too short to fit, steps far from linear in the control); each in turn claims every demonstration left whose miss it cuts to a quarter (zeros: a sixteenth, and
    only where every control of the demonstration is 0 and others are not)."""
    odd = _odd(problem, states, controls) if len(states) > 1 else []
    if len(odd) == 0:
        return []
    together = odd[spread(len(odd), most // max(states.shape[1], 1))]
    fits = [_control_motion(problem, states[together], controls[together], usual=False)]
    fits += [_control_motion(problem, states[d:d + 1], controls[d:d + 1], usual=False) for d in odd[:alone]]
    changes = [(f.kind, f.M, f.c) for f in fits if f and _unit_like(f.kind, f.M)] + [(k, M, None) for k, M in _candidates(
        controls.shape[2])]
    zero = np.array([np.all(c[np.isfinite(c)] == 0) for c in controls])
    groups, left = [], np.asarray(odd)
    for kind, M, c in changes:
        c = np.zeros(controls.shape[2]) if kind == "mapped" and c is None else c
        able = left[~zero[left]] if kind != "zeros" else left[zero[left]] if not zero.all() else left[:0]
        if not able.size:
            continue
        changed, recorded = _remedied(problem, states[able], controls[able], kind, M, c)
        claimed = changed * (16 if kind == "zeros" else 4) < recorded
        if claimed.any():
            take = able[claimed]
            groups.append((sorted(take.tolist()), _found(problem, kind, np.mean(recorded[claimed]),
                                                         np.mean(changed[claimed]), M, c)))
            left = np.setdiff1d(left, take)
    return groups


def _remedied(problem, states, controls, kind, M=None, c=None):
    """Each demonstration's mean squared miss with the change of ``kind`` made to its recorded controls, and as
    recorded, on the same steps."""
    if kind == "mapped":
        return per_demonstration(problem, states, controls @ M.T + c), per_demonstration(problem, states, controls)
    if kind == "zeros":
        return per_demonstration(problem, states, None), per_demonstration(problem, states, controls)
    if kind == -1:        # step k under the control of step k - 1
        return (per_demonstration(problem, states[:, 1:], controls[:, :-1]),
                per_demonstration(problem, states[:, 1:], controls[:, 1:]))
    return (per_demonstration(problem, states[:, :-1], controls[:, 1:]),
            per_demonstration(problem, states[:, :-1], controls[:, :-1]))


class Found(NamedTuple):
    """What explains recorded steps better than their recorded controls: ``kind`` "zeros", "mapped" (by ``M u + c``)
    or the shift (-1 or 1), and the warning's ``text``."""

    kind: object
    text: str
    M: np.ndarray | None = None
    c: np.ndarray | None = None


def _unit_like(kind, M=None):
    """Whether a change of ``kind`` (by ``M``) is one of unit (a factor beyond [0.5, 2]), sign or columns, a shift
    or zeros."""
    if kind != "mapped":
        return True
    column = np.argmax(np.abs(M), axis=1)
    return bool(np.any(column != np.arange(len(M))) or np.any(M[np.arange(len(M)), column] < 0) or _scaled(M))


def _scaled(M):
    """Whether a control's largest entry of ``M`` is a factor beyond [0.5, 2] in size (a unit, not a sign or an
    exchange)."""
    size = np.abs(M).max(axis=1)
    return bool(np.any((size < 0.5) | (size > 2)))


def _control_motion(problem, states, controls, usual=True):
    """The :class:`Found` of :func:`check_control_motion`, or None; ``usual``: try the usual mistakes as they are
    too (:func:`_best_usual`)."""
    L, m = controls.shape[1], controls.shape[2]
    u = controls.reshape(-1, m)
    u = u[np.isfinite(u).all(axis=1)]
    if len(u) < 4 * (m * m + m):                               # too few steps to fit M and c
        return None
    recorded = mean_miss(problem, states, controls)            # clipped to the set's range: what acted at most
    if not recorded > 0.02 ** 2:
        return None
    if np.all(u == 0):
        best = mean_miss(problem, states, None)               # each step's best control: fits noise too, so 16x
        return _found(problem, "zeros", recorded, best) if 16 * best < recorded else None
    fits, M, c = {}, *_control_map(problem, states, controls)
    if M is not None and _describe(M, c, problem):
        fits["mapped"] = (mean_miss(problem, states, controls @ M.T + c), recorded)
    best = _best_usual(problem, states, controls, u) if usual else None   # for steps far from linear in the control
    if best and best[0] * _margin(fits, M) < fits.get("mapped", (recorded,))[0]:    # (turns of radians), which the
        M, c, fits["mapped"] = best[1], np.zeros(m), (best[0], recorded)           # linearised fit misses
    if L > 1:      # step k under the control of step k - 1 (shift -1) or k + 1 (shift 1), on the steps both have
        late, early = states[:, 1:], states[:, :-1]
        fits[-1] = (mean_miss(problem, late, controls[:, :-1]), mean_miss(problem, late, controls[:, 1:]))
        fits[1] = (mean_miss(problem, early, controls[:, 1:]), mean_miss(problem, early, controls[:, :-1]))
    cut = {k: mine / max(other, 1e-300) for k, (other, mine) in fits.items()}
    best = max(cut, key=cut.get, default=None)
    if best is None or cut[best] < 4:
        return None
    return _found(problem, best, fits[best][1], fits[best][0], *((M, c) if best == "mapped" else ()))


def _found(problem, kind, recorded, changed, M=None, c=None):
    """The :class:`Found` of a change of ``kind`` whose steps miss by ``changed`` where the recorded controls' miss
    by ``recorded`` (mean squared, cell widths)."""
    if kind == "zeros":
        return Found(kind, f"every recorded control is 0, but the motion needs others (a step with the best control of "
                           f"the set misses the next state by {np.sqrt(changed):.3g} cell widths, rms; with 0 by "
                           f"{np.sqrt(recorded):.3g}): were missing values written as 0? leave them empty")
    if kind == "mapped":
        mild = not _unit_like(kind, M)      # also what other masses, gains or frictions give
        what, hint = "changed", (f"the controls that explain the steps are "
                                f"{_describe(M, c, problem)}: " + (
                                    "the system's parameters (a heavier system, a weaker actuator) or the units "
                                    "differ from the model's" if mild else "check the units, signs and columns"))
    else:
        what, hint = "shifted", (f"the steps follow the control recorded one step (dt = {problem.dt:g} s) "
                                 f"{'later' if kind > 0 else 'earlier'}: each row's control acts from its t on")
    return Found(kind, f"the recorded controls do not explain the recorded motion: steps with them miss the next "
                       f"state by {np.sqrt(recorded):.3g} cell widths (rms), steps with the {what} ones by "
                       f"{np.sqrt(changed):.2g}; {hint}", M, c)


def _candidates(m):
    """The changes tried as they are beside the fitted map (which a step far from linear in the control escapes)
    and where a demonstration is too short to fit: no, one or every sign reversed, with or without two controls
    exchanged; each control or all at once times 10^k (k = -3..3, not 0), pi/180 or 180/pi (degrees and radians);
    the shift by one row either way; zeros."""
    eye = np.eye(m)
    swaps = [eye] + [eye[[k if i == j else j if i == k else i for i in range(m)]] for j in range(m) for k in range(j + 1, m)]
    signs = [np.ones(m)] + [np.where(np.arange(m) == j, -1.0, 1.0) for j in range(m)] + [-np.ones(m)] * (m > 1)
    out = [("mapped", sign[:, None] * P) for P in swaps for sign in signs][1:]       # all but the identity
    for factor in (1e-3, 1e-2, 1e-1, 1e1, 1e2, 1e3, np.pi / 180, 180 / np.pi):
        for j in range(m):
            M = eye.copy()
            M[j, j] = factor
            out.append(("mapped", M))
        out += [("mapped", factor * eye)] if m > 1 else []
    return out + [(-1, None), (1, None), ("zeros", None)]


def _margin(fits, M):
    """How much better than the fitted map (or, without one, than the recorded controls) a usual mistake must do to
    be named instead: any better than a map that is itself a change of unit, sign or columns (the same mistake,
    roughly fitted), 4 times better than a mild one (what another mass or gain also gives) or than none."""
    return 1.0 if "mapped" in fits and _unit_like("mapped", M) else 4.0


def _best_usual(problem, states, controls, u):
    """``(miss, M)``: the usual mistake (:func:`_candidates`, as it is) whose steps miss least (mean squared, cell
    widths), among those that keep the recorded controls ``u`` (k, m) within the set's range; None if none does."""
    usual = [M for kind, M in _candidates(u.shape[1]) if kind == "mapped" and _within(problem, u @ M.T)]
    return min(((mean_miss(problem, states, controls @ M.T), M) for M in usual), key=lambda pair: pair[0], default=None)


def _within(problem, u, share=0.95):
    """Whether ``share`` of the controls u (k, m) lie within the set's range, give or take a tenth of it: a change
    that puts the recorded controls far outside it would explain steps only by the clipping to the range."""
    low, high = problem.controls.min(axis=0), problem.controls.max(axis=0)
    slack = 0.1 * (high - low)
    return bool(np.mean(np.all((u >= low - slack) & (u <= high + slack), axis=1)) >= share)


def _control_map(problem, states, controls):
    """``(M, c)`` minimising the linearised miss of steps under M u + c: x' ~ step(x, u0) + B(x) (M u + c - u0)
    about the middle u0 of the set's range, B(x) by central differences of a hundredth of the range; the offset
    only where the recorded values vary. ``(None, None)`` when the recorded columns cannot be told apart."""
    n, m, grid = states.shape[2], controls.shape[2], problem.grid
    x, nxt, u = recorded_steps(problem, states, controls)
    low, high = problem.controls.min(axis=0), problem.controls.max(axis=0)
    middle, delta = (low + high) / 2, np.where(high > low, (high - low) / 100, 1e-3)
    ones = np.ones((len(x), 1))
    B = np.stack([difference(grid, problem.step(x, ones * (middle + delta[j] * np.eye(m)[j])),
                              problem.step(x, ones * (middle - delta[j] * np.eye(m)[j]))) / (2 * delta[j])
                  for j in range(m)], axis=2)                        # (k, n, m): cell widths per unit of control
    target = difference(grid, nxt, problem.step(x, ones * middle)) + B @ middle
    vary = np.ptp(u, axis=0) > 0
    design = np.concatenate([(B[:, :, :, None] * u[:, None, None, :]).reshape(len(x), n, m * m), B[:, :, vary]], 2)
    fit, _, rank, _ = np.linalg.lstsq(design.reshape(len(x) * n, -1), target.ravel(), rcond=None)
    if rank < design.shape[2]:
        return None, None
    offset = np.zeros(m)
    offset[vary] = fit[m * m:]
    return fit[:m * m].reshape(m, m), offset


DEGREES = ((np.pi / 180, "recorded in degrees where the model takes radians?"),
           (180 / np.pi, "recorded in radians where the model takes degrees?"))


def _describe(M, c, problem):
    """``'torque' about 1000 times the recorded one``, ``'vx' about 1 times the recorded 'vy'`` (the largest
    entry of each row), ``minus 1.5`` (an offset beyond a tenth of the set's range), for the controls changed (a
    factor of pi/180 or 180/pi on an angle or its rate named as degrees); "" when none is."""
    names, units = problem.system.control_names, problem.system.control_units
    span, out = problem.controls.max(axis=0) - problem.controls.min(axis=0), []
    for i, row in enumerate(M):
        j = int(np.argmax(np.abs(row)))
        offset = f" {'plus' if c[i] > 0 else 'minus'} {abs(c[i]):.3g}" if abs(c[i]) > 0.1 * span[i] else ""
        if j == i and 0.8 <= row[j] <= 1.25 and not offset:
            continue
        one = "one" if j == i else repr(names[j])
        sign = " (its sign looks reversed)" if j == i and row[j] < 0 else ""
        angle = j == i and any(a in str(units[i]).lower() for a in ("rad", "deg"))
        sign += next((f" ({said})" for factor, said in DEGREES if angle and abs(row[j] / factor - 1) < 0.02), "")
        out.append(f"{names[i]!r} about {row[j] + 0.0:.4g} times the recorded {one}{offset}{sign}")
    return ", ".join(out)
