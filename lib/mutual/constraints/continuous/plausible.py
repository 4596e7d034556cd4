"""What a user gets wrong in recordings that still read (:func:`check_plausible`): refused or warned about.

Refused: demonstrations longer than the horizon; time that runs backwards (the states follow the dynamics
backwards). Warned about (:class:`mutual.inputs.InputWarning`): periodic angles that look like degrees (the
dynamics decide where they can); recorded controls far outside the control set; recorded controls that do not
explain the recorded motion (a unit, a sign, exchanged columns, a shift by one row, or zeros for missing values),
in the whole file or in the demonstrations that stand out; demonstrations that reach the edge of the box.
Distances between states are in cell widths (periodic coordinates the short way).
"""

from typing import NamedTuple

import numpy as np

from ...inputs import angle_unit_warning, warn


def check_plausible(problem, recording, states, controls, index):
    """The module docstring's checks of ``recording``, given its aligned ``states`` (N, L+1, n), ``controls``
    (N, L, m) or None and sample ``index`` (:func:`.recordings.align`): a ValueError or warnings."""
    L = states.shape[1] - 1
    if L > problem.horizon:
        raise ValueError(f"{recording.where(0, index[0, -1], 't')}: the demonstrations span {L} steps of dt = "
                         f"{problem.dt:g} s, more than the horizon T = {problem.horizon} of the system ([time] "
                         f"horizon); raise the horizon to at least {L}, or trim the recordings")
    _check_time_direction(problem, recording, states)
    periodic = np.flatnonzero(problem.grid.periodic)
    degrees = any([_check_angle_unit(problem, recording, states, controls, i) for i in periodic])
    if recording.controls is not None:
        _check_control_range(problem, recording)
        if not degrees:  # angles in another unit also leave the controls unexplained: one cause, said once
            _check_control_motion(problem, recording, states, controls)
    _check_box_edges(problem, recording, states)


def _check_angle_unit(problem, recording, states, controls, i):
    """Warn when the periodic coordinate ``i`` looks like degrees, and say whether it did. The dynamics decide where
    they can (:func:`_as_degrees`): steps they explain far better (a sixteenth of the mean squared miss) when the
    column is read as degrees are named; where they explain the steps as recorded (the best control's step, or the
    recorded control's, lands within a cell, rms), only values more than a turn beyond the box count (a fast
    vehicle at a long dt turns more than a quarter turn a step); elsewhere steps of more than a quarter turn count
    as well (:func:`mutual.inputs.angle_unit_warning`)."""
    grid = problem.grid
    where = f"{recording.source}, column {grid.names[i]!r} (periodic, radians)"
    misses = _as_degrees(problem, states, i)
    if misses is not None and 16 * misses[1] < misses[0] and misses[0] > 0.02 ** 2:
        warn(f"{where}: the angles look like degrees, not radians: the dynamics explain the recorded steps when they "
             f"are read as degrees (the best control's step misses the next state by {np.sqrt(misses[0]):.3g} cell "
             f"widths, rms, as recorded; by {np.sqrt(misses[1]):.2g} read as degrees); if so, multiply by pi/180")
        return True
    tracks = [s[:, i] for s in recording.states]
    if misses is not None and (misses[0] < 1 or _recorded_miss(problem, states, controls) < 1):
        message = angle_unit_warning(np.concatenate(tracks), where, grid.low[i], grid.high[i])  # values only
    else:
        message = angle_unit_warning(tracks, where, grid.low[i], grid.high[i], times=recording.times)
    if message:
        warn(message)
    return bool(message)


def _recorded_miss(problem, states, controls):
    """The mean squared miss (cell widths) of the steps under their recorded controls clipped to the set's range;
    infinite without recorded controls or where the dynamics fail."""
    if controls is None:
        return np.inf
    try:
        low, high = problem.controls.min(axis=0), problem.controls.max(axis=0)
        return _mean_miss(problem, states, np.clip(controls, low, high))
    except ValueError:
        return np.inf


def _as_degrees(problem, states, i, most=2000):
    """``(as recorded, as degrees)``: the mean squared miss (cell widths) of the best control's step over up to
    ``most`` recorded steps (spread), with the periodic coordinate ``i`` as recorded and read as degrees (times
    pi/180, its miss still counted in recorded units); None where the dynamics fail."""
    n = states.shape[2]
    x, nxt = states[:, :-1].reshape(-1, n), states[:, 1:].reshape(-1, n)
    pick = _spread(len(x), most)
    x, nxt = x[pick], nxt[pick]
    radians = np.where(np.arange(n) == i, np.pi / 180, 1.0)

    widths = np.array([np.min(problem.grid.widths_1d(j)) for j in range(n)])

    def miss(a, b, unit=1.0):   # in the recorded units: noise on the angle is not shrunk with it
        wrap = problem.grid.wrap
        return float(np.mean(step_misses(problem, wrap(a), wrap(b), widths * unit).min(axis=1) ** 2))
    try:
        return miss(x, nxt), miss(x * radians, nxt * radians, radians)
    except ValueError:
        return None


def _check_box_edges(problem, recording, states):
    """Warn where the demonstrations reach an edge of the box on a coordinate that does not wrap (within a
    quarter of the edge cell): the box may be what holds them there, and a bound found there cannot be
    told from the box's own edge."""
    grid = problem.grid
    flat = states.reshape(-1, grid.ndim)
    for i in np.flatnonzero(~np.asarray(grid.periodic)):
        widths = grid.widths_1d(i)
        low, high = flat[:, i].min(), flat[:, i].max()
        reached = [f"down to {low:.6g} (low = {grid.low[i]:g})"] if low - grid.low[i] < widths[0] / 4 else []
        reached += [f"up to {high:.6g} (high = {grid.high[i]:g})"] if grid.high[i] - high < widths[-1] / 4 else []
        if reached:
            warn(f"{recording.source}, column {grid.names[i]!r}: the demonstrations reach the edge of the box, "
                 f"{' and '.join(reached)}, within a quarter cell: the box may be what holds them there, and a bound "
                 "found there cannot be told from the box's edge; widen [state] low/high to see what limits them")


def _check_control_range(problem, recording):
    """Warn about recorded controls more than the control set's width outside it (each is snapped to its edge)."""
    names = problem.system.control_names
    for j, name in enumerate(names):
        lo, hi = problem.controls[:, j].min(), problem.controls[:, j].max()
        width = hi - lo if hi > lo else max(abs(lo), 1.0)
        far = [np.flatnonzero((c[:, j] < lo - width) | (c[:, j] > hi + width)) for c in recording.controls]
        count = sum(f.size for f in far)
        if count:
            d = next(k for k, f in enumerate(far) if f.size)
            total = sum(int(np.isfinite(c[:, j]).sum()) for c in recording.controls)
            top = max(float(np.nanmax(np.abs(c[:, j]))) for c in recording.controls)
            warn(f"{recording.where(d, far[d][0], name)}: {count} of {total} recorded {name!r} values lie more than "
                 f"the control set's width outside it ([{lo:g}, {hi:g}]; up to {top:.4g} in magnitude); each is "
                 "snapped to the nearest control of the set, so check the unit (or widen [control] values)")


def _check_control_motion(problem, recording, states, controls, most=4000):
    """Warn when the recorded controls do not explain the recorded motion: one step is close to linear in the
    control, so the map M (m x m) and offset c for which steps under M u + c best explain the motion are fitted
    by least squares (and steps under the control one step of dt earlier or later are tried); when one of them
    cuts the mean squared miss of the next states to a quarter of what the controls as recorded give (clipped to
    the set's range, as the models take them), and the miss is more than a fiftieth of a cell, what changed is
    named: a factor per control, exchanged columns, an offset, or the shift. Every recorded control 0 while the
    motion needs others is said apart (missing values written as 0?). The whole file is fitted on up to ``most``
    steps of demonstrations spread over it. When it passes, every demonstration is scored under its recorded
    controls, and those that stand out are named where a unit, a sign, exchanged columns, a shift or zeros explain
    them (:func:`_odd_groups`); a fit needs 4 (m^2 + m) recorded steps, so a single shorter demonstration is not
    fitted alone. Dynamics that fail on a control the check tries leave it unsaid (the model's own steps report
    such a failure)."""
    demos = _spread(len(states), most // max(states.shape[1], 1))
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
        units = "; were they recorded in other units?" if found.kind == "mapped" else ""
        warn(f"{recording.source}, {where}: demonstrations {ids} ({len(group)} of {len(states)}) follow their recorded "
             f"controls far worse than the others do: {found.text}{units}")


def _per_demonstration(problem, states, controls):
    """Each demonstration's mean squared miss (cell widths) of its steps under ``controls`` (N, L, m), clipped to
    the set's range, where recorded (None: the best control of the set, step by step); NaN without a step."""
    N, L, n = states.shape[0], states.shape[1] - 1, states.shape[2]
    x, nxt, _ = _steps(problem, states)
    squared, ok = np.zeros(N * L), np.ones(N * L, bool)
    if controls is None:
        squared = step_misses(problem, x, nxt).min(axis=1) ** 2
    else:
        u = np.clip(controls.reshape(N * L, -1), problem.controls.min(axis=0), problem.controls.max(axis=0))
        ok = np.isfinite(u).all(axis=1)
        squared[ok] = _distance(problem.grid, problem.step(x[ok], u[ok]), nxt[ok]) ** 2
    counts = ok.reshape(N, L).sum(axis=1)
    return np.where(counts > 0, squared.reshape(N, L).sum(axis=1) / np.maximum(counts, 1), np.nan)


def _odd(problem, states, controls):
    """The demonstrations that stand out, worst first: the mean squared miss of their steps under their recorded
    controls is above 4 times that of the demonstration at the 5th percentile of those that move (one that sits
    still or a few lucky ones set no standard) and above a fiftieth of a cell."""
    miss = _per_demonstration(problem, states, controls)
    moves = np.isfinite(miss) & (np.ptp(states, axis=1).max(axis=1) > 0)
    if not moves.any():
        return np.zeros(0, int)
    typical = np.percentile(miss[moves], 5)
    odd = np.flatnonzero((miss > 4 * typical) & (miss > 0.02 ** 2))
    return odd[np.argsort(-miss[odd], kind="stable")]


def _odd_groups(problem, states, controls, alone=20):
    """``[(demonstrations, found)]``: the demonstrations that stand out (:func:`_odd`) and what explains them where
    it is a change of unit, sign or columns, a shift or zeros (an offset or a mild factor is also what an
    unmodelled force or a weaker actuator gives). The changes: fitted to them together and to the worst ``alone``
    each alone (:func:`_control_motion`), then the :func:`_candidates` as they are (a demonstration too short to
    fit); each in turn claims every demonstration left whose miss it cuts to a quarter (zeros: a sixteenth, and
    only where every control of the demonstration is 0 and others are not)."""
    odd = _odd(problem, states, controls) if len(states) > 1 else []
    if len(odd) == 0:
        return []
    fits = [_control_motion(problem, states[odd], controls[odd])]
    fits += [_control_motion(problem, states[d:d + 1], controls[d:d + 1]) for d in odd[:alone]]
    changes = [(f.kind, f.M, f.c) for f in fits if f and f.unit_like] + [(k, M, None) for k, M in _candidates(
        controls.shape[2])]
    zero = np.array([np.all(c[np.isfinite(c)] == 0) for c in controls])
    groups, left = [], np.asarray(odd)
    for kind, M, c in changes:
        c = np.zeros(controls.shape[2]) if kind == "mapped" and c is None else c
        able = left[~zero[left]] if kind != "zeros" else left[zero[left]] if not zero.all() else left[:0]
        if not able.size:
            continue
        found = Found(kind, "", M, c)
        changed, recorded = _remedied(problem, states[able], controls[able], found)
        claimed = changed * (16 if kind == "zeros" else 4) < recorded
        if claimed.any():
            take = able[claimed]
            groups.append((sorted(take.tolist()), _found(problem, kind, np.mean(recorded[claimed]),
                                                         np.mean(changed[claimed]), M, c)))
            left = np.setdiff1d(left, take)
    return groups


def _remedied(problem, states, controls, found):
    """Each demonstration's mean squared miss with ``found``'s change made to its recorded controls, and as
    recorded, on the same steps."""
    if found.kind == "mapped":
        return _per_demonstration(problem, states, controls @ found.M.T + found.c), _per_demonstration(
            problem, states, controls)
    if found.kind == "zeros":
        return _per_demonstration(problem, states, None), _per_demonstration(problem, states, controls)
    if found.kind == -1:        # step k under the control of step k - 1
        return (_per_demonstration(problem, states[:, 1:], controls[:, :-1]),
                _per_demonstration(problem, states[:, 1:], controls[:, 1:]))
    return (_per_demonstration(problem, states[:, :-1], controls[:, 1:]),
            _per_demonstration(problem, states[:, :-1], controls[:, :-1]))


def _spread(n, keep):
    """At most ``keep`` (at least 1) indices spread evenly over range(n)."""
    return np.unique(np.linspace(0, n - 1, max(1, min(n, keep))).astype(int))


class Found(NamedTuple):
    """What explains recorded steps better than their recorded controls: ``kind`` "zeros", "mapped" (by ``M u + c``)
    or the shift (-1 or 1), and the warning's ``text``."""

    kind: object
    text: str
    M: np.ndarray | None = None
    c: np.ndarray | None = None

    @property
    def unit_like(self):
        """Whether it is a change of unit (a factor beyond [0.5, 2]), sign or columns, a shift or zeros."""
        if self.kind != "mapped":
            return True
        column = np.argmax(np.abs(self.M), axis=1)
        factor = self.M[np.arange(len(self.M)), column]
        return bool(np.any(column != np.arange(len(self.M))) or np.any((factor < 0.5) | (factor > 2)))


def _control_motion(problem, states, controls):
    """The :class:`Found` of :func:`_check_control_motion`, or None."""
    L, m = controls.shape[1], controls.shape[2]
    low, high = problem.controls.min(axis=0), problem.controls.max(axis=0)
    raw, controls = controls, np.clip(controls, low, high)     # what acted at most: the set's range
    u = raw.reshape(-1, m)
    u = u[np.isfinite(u).all(axis=1)]
    if len(u) < 4 * (m * m + m):                               # too few steps to fit M and c
        return None
    recorded = _mean_miss(problem, states, controls)
    if not recorded > 0.02 ** 2:
        return None
    if np.all(u == 0):
        best = _mean_miss(problem, states, None)               # each step's best control: fits noise too, so 16x
        return _found(problem, "zeros", recorded, best) if 16 * best < recorded else None
    fits, M, c = {}, *_control_map(problem, states, raw)
    if M is not None and _describe(M, c, high - low, problem.system.control_names):
        fits["mapped"] = (_mean_miss(problem, states, np.clip(raw @ M.T + c, low, high)), recorded)
    if L > 1:      # step k under the control of step k - 1 (shift -1) or k + 1 (shift 1), on the steps both have
        late, early = states[:, 1:], states[:, :-1]
        fits[-1] = (_mean_miss(problem, late, controls[:, :-1]), _mean_miss(problem, late, controls[:, 1:]))
        fits[1] = (_mean_miss(problem, early, controls[:, 1:]), _mean_miss(problem, early, controls[:, :-1]))
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
        span = problem.controls.max(axis=0) - problem.controls.min(axis=0)
        mild = not Found(kind, "", M, c).unit_like   # also what other masses, gains or frictions give
        what, hint = "fitted", (f"the controls that explain the steps are "
                                f"{_describe(M, c, span, problem.system.control_names)}: " + (
                                    "the system's parameters (a heavier system, a weaker actuator) or the units "
                                    "differ from the model's" if mild else "check the units, signs and columns"))
    else:
        what, hint = "shifted", (f"the steps follow the control recorded one step (dt = {problem.dt:g} s) "
                                 f"{'later' if kind > 0 else 'earlier'}: each row's control acts from its t on")
    return Found(kind, f"the recorded controls do not explain the recorded motion: steps with them miss the next "
                       f"state by {np.sqrt(recorded):.3g} cell widths (rms), steps with the {what} ones by "
                       f"{np.sqrt(changed):.2g}; {hint}", M, c)


def _candidates(m):
    """The changes tried as they are where a demonstration is too short to fit: each control's sign reversed or
    times 10^k (k = -3..3, also all controls at once), two controls exchanged, the shift by one row either way,
    zeros."""
    eye, out = np.eye(m), []
    for factor in (-1.0, 1e-3, 1e-2, 1e-1, 1e1, 1e2, 1e3):
        for j in range(m):
            M = eye.copy()
            M[j, j] = factor
            out.append(("mapped", M))
        out += [("mapped", factor * eye)] if m > 1 and factor > 0 else []
    for j in range(m):
        for k in range(j + 1, m):
            out.append(("mapped", eye[[k if i == j else j if i == k else i for i in range(m)]]))
    return out + [(-1, None), (1, None), ("zeros", None)]


def _steps(problem, states, controls=None):
    """``(x, next, u)``: the steps states[:, k] -> states[:, k + 1] flattened and wrapped, with their controls
    (N, L, m) where all are recorded (u None: every step)."""
    n = states.shape[2]
    x, nxt = problem.grid.wrap(states[:, :-1].reshape(-1, n)), problem.grid.wrap(states[:, 1:].reshape(-1, n))
    if controls is None:
        return x, nxt, None
    u = controls.reshape(len(x), -1)
    ok = np.isfinite(u).all(axis=1)
    return x[ok], nxt[ok], u[ok]


def _mean_miss(problem, states, controls):
    """The mean squared miss (cell widths) of one step from states[:, k] under controls[:, k] to states[:, k + 1]
    over the recorded steps; controls None: under the best control of the set, step by step."""
    x, nxt, u = _steps(problem, states, controls)
    if u is None:
        return float(np.mean(step_misses(problem, x, nxt).min(axis=1) ** 2))
    return float(np.mean(_distance(problem.grid, problem.step(x, u), nxt) ** 2)) if len(u) else 0.0


def _control_map(problem, states, controls):
    """``(M, c)`` minimising the linearised miss of steps under M u + c: x' ~ step(x, u0) + B(x) (M u + c - u0)
    about the middle u0 of the set's range, B(x) by central differences of a hundredth of the range; the offset
    only where the recorded values vary. ``(None, None)`` when the recorded columns cannot be told apart."""
    n, m, grid = states.shape[2], controls.shape[2], problem.grid
    x, nxt, u = _steps(problem, states, controls)
    low, high = problem.controls.min(axis=0), problem.controls.max(axis=0)
    middle, delta = (low + high) / 2, np.where(high > low, (high - low) / 100, 1e-3)
    ones = np.ones((len(x), 1))
    B = np.stack([_difference(grid, problem.step(x, ones * (middle + delta[j] * np.eye(m)[j])),
                              problem.step(x, ones * (middle - delta[j] * np.eye(m)[j]))) / (2 * delta[j])
                  for j in range(m)], axis=2)                        # (k, n, m): cell widths per unit of control
    target = _difference(grid, nxt, problem.step(x, ones * middle)) + B @ middle
    vary = np.ptp(u, axis=0) > 0
    design = np.concatenate([(B[:, :, :, None] * u[:, None, None, :]).reshape(len(x), n, m * m), B[:, :, vary]], 2)
    fit, _, rank, _ = np.linalg.lstsq(design.reshape(len(x) * n, -1), target.ravel(), rcond=None)
    if rank < design.shape[2]:
        return None, None
    offset = np.zeros(m)
    offset[vary] = fit[m * m:]
    return fit[:m * m].reshape(m, m), offset


def _describe(M, c, span, names):
    """``'torque' about 1000 times the recorded one``, ``'vx' about 1 times the recorded 'vy'`` (the largest
    entry of each row), ``minus 1.5`` (an offset beyond a tenth of the set's range), for the controls changed;
    "" when none is."""
    out = []
    for i, row in enumerate(M):
        j = int(np.argmax(np.abs(row)))
        offset = f" {'plus' if c[i] > 0 else 'minus'} {abs(c[i]):.3g}" if abs(c[i]) > 0.1 * span[i] else ""
        if j == i and 0.8 <= row[j] <= 1.25 and not offset:
            continue
        one = "one" if j == i else repr(names[j])
        sign = " (its sign looks reversed)" if j == i and row[j] < 0 else ""
        out.append(f"{names[i]!r} about {row[j] + 0.0:.4g} times the recorded {one}{offset}{sign}")
    return ", ".join(out)


def _difference(grid, a, b, widths=None):
    """a - b in cell widths, periodic coordinates the short way round; ``widths`` the cell widths to count in
    (broadcast against a - b), by default each coordinate's narrowest."""
    diff = a - b
    for i in np.flatnonzero(grid.periodic):
        period = grid.high[i] - grid.low[i]
        diff[..., i] = np.mod(diff[..., i] + period / 2, period) - period / 2
    if widths is None:
        widths = np.array([np.min(grid.widths_1d(i)) for i in range(grid.ndim)])
    return diff / widths


def _distance(grid, a, b, widths=None):
    """Distances (in cell widths, periodic coordinates the short way round) between states a (..., n) and b."""
    return np.sqrt((_difference(grid, a, b, widths) ** 2).sum(axis=-1))


def step_misses(problem, x, nxt, widths=None):
    """(k, A): each control's one-step prediction's distance from the states x (k, n) to nxt (k, n), in cell widths
    (``widths`` as for :func:`_difference`)."""
    A = problem.n_actions
    pred = problem.step(np.repeat(x, A, axis=0), np.tile(problem.controls, (len(x), 1))).reshape(len(x), A, -1)
    return _distance(problem.grid, pred, nxt[:, None, :], widths)


def _check_time_direction(problem, recording, states, most=2000):
    """Refuse recordings whose states, in the order of t, follow the dynamics backwards: each step's best one-step
    prediction misses the next state by more than half the step, while a step taken from the next state lands
    on the previous one (a quarter of that miss or nearer)."""
    x, nxt, _ = _steps(problem, states)
    pick = _spread(len(x), most)
    x, nxt = x[pick], nxt[pick]
    forward = float(np.median(step_misses(problem, x, nxt).min(axis=1)))
    step = float(np.median(_distance(problem.grid, nxt, x)))
    if not forward > max(0.5 * step, 0.05):           # the dynamics explain the steps (or nothing moves)
        return
    backward = float(np.median(step_misses(problem, nxt, x).min(axis=1)))
    if backward < 0.25 * forward:
        raise ValueError(f"{recording.source}, column 't': the recorded motion runs backwards in time: in the order "
                         f"of t, the dynamics' best one-step prediction misses the next state by {forward:.3g} cell "
                         f"widths (median; the steps are {step:.3g}), but a step from the next state lands "
                         f"{backward:.3g} from the previous one; t seems to decrease along the motion (a time-to-go, "
                         "or its sign): make t increase as the motion goes")
