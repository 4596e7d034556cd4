"""Recorded continuous trajectories: their CSV format and their alignment to the model's time step.

Trajectory CSV (``read_recording`` / ``write_recording``; data/README.md): a header ``demo, t``,
then one column per state coordinate (the system's names) and optionally one per control; one row
per recorded sample. ``demo`` is any text naming the demonstration (rows of one demonstration
together or not: they are ordered by ``t``), ``t`` is in seconds, sampled at a regular period; a
control may be empty where it was not recorded, and is ignored on each demonstration's last row.

:func:`align` keeps every k-th sample so that steps are ``dt`` apart (the period must divide ``dt``);
:mod:`.mapping` then maps the states to cells and the steps to actions.
"""

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ...atomic import atomic_path
from ...inputs import angle_unit_warning, name_column, number_column, read_csv, warn

_TOLERANCE = 1e-6   # relative: equal sampling periods, a period dividing dt


@dataclass(frozen=True, eq=False)
class Recording:
    """Continuous demonstrations: ``ids`` (text), and per demonstration ``times`` (L+1,), ``states``
    (L+1, n) and ``controls`` (L+1, m) (nan where not recorded) or None (no control columns).
    ``lines`` (per demonstration, the file line of each sample) and ``source`` name the origin."""

    ids: tuple
    times: tuple
    states: tuple
    controls: tuple = None
    lines: tuple = None
    source: str = "recording"
    notes: dict = field(default_factory=dict)

    def __len__(self):
        return len(self.ids)

    def __repr__(self):
        return (f"Recording({len(self)} demonstrations from {self.source}, "
                f"{'with' if self.controls is not None else 'without'} controls)")

    def line(self, d, k):
        return None if self.lines is None else int(self.lines[d][k])

    def where(self, d, k, column):
        """``'SOURCE, line L, column C'`` (or demo and sample) for error messages."""
        line = self.line(d, k)
        at = f"line {line}" if line is not None else f"demo {self.ids[d]!r}, sample {k}"
        return f"{self.source}, {at}, column {column!r}"


def recording_frame(recording, state_names, control_names=None):
    """The recording as a DataFrame in the CSV format (controls empty where not recorded)."""
    frames = []
    for d, ident in enumerate(recording.ids):
        frame = pd.DataFrame({"demo": ident, "t": recording.times[d]})
        for i, name in enumerate(state_names):
            frame[name] = recording.states[d][:, i]
        if recording.controls is not None and control_names:
            for j, name in enumerate(control_names):
                frame[name] = recording.controls[d][:, j]
        frames.append(frame)
    return pd.concat(frames, ignore_index=True)


def write_recording(path, recording, state_names, control_names=None):
    """Write a recording atomically as trajectory CSV (module docstring)."""
    frame = recording_frame(recording, state_names, control_names)
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False, float_format="%.10g")
    return path


def read_recording(path, state_names, control_names=()):
    """Read trajectory CSV (module docstring; :func:`mutual.inputs.read_csv`); every problem raises a
    ValueError naming the file, the line (1 = the header) and the column. Demonstration names that differ
    only by surrounding spaces are refused as ambiguous."""
    frame = read_csv(path, ("demo", "t", *state_names))
    ids = name_column(frame, "demo").to_numpy()
    t = number_column(frame, "t")
    states = np.stack([number_column(frame, c) for c in state_names], axis=1)
    present = [c for c in control_names if c in frame.columns]
    if present and len(present) != len(control_names):
        raise ValueError(f"{path}, line 1: has control column {present[0]!r} but not "
                         f"{[c for c in control_names if c not in present][0]!r}; give all controls or none")
    controls = np.stack([number_column(frame, c, True) for c in control_names], axis=1) if present else None
    line = np.asarray(frame.attrs["lines"])
    out = {"ids": [], "times": [], "states": [], "controls": [], "lines": []}
    codes, names = pd.factorize(ids)                       # in order of first appearance
    order = np.lexsort((t, codes))                         # by demonstration, then by t (ties as in the file)
    for ident, rows in zip(names, np.split(order, np.flatnonzero(np.diff(codes[order])) + 1)):
        if rows.size < 2:
            raise ValueError(f"{path}, line {line[rows[0]]}, column 'demo': demonstration {ident!r} has one row; "
                             "a demonstration needs at least two samples")
        for key, value in (("ids", ident), ("times", t[rows]), ("states", states[rows]), ("lines", line[rows]),
                           ("controls", None if controls is None else controls[rows])):
            out[key].append(value)
    return Recording(tuple(out["ids"]), tuple(out["times"]), tuple(out["states"]),
                     None if controls is None else tuple(out["controls"]), tuple(out["lines"]), str(path))


def _stride(recording, d, dt):
    """Samples per step of ``dt`` in demonstration d, checking the sampling is regular."""
    t = recording.times[d]
    steps = np.diff(t)
    period = steps[0]
    repeated = np.flatnonzero(steps <= 0)
    if repeated.size:
        k = int(repeated[0]) + 1
        raise ValueError(f"{recording.where(d, k, 't')}: time {t[k]:g} repeats the previous sample's time")
    off = np.flatnonzero(np.abs(steps - period) > _TOLERANCE * max(period, 1e-12) + 1e-12)
    if off.size:
        k = int(off[0]) + 1
        what = "a gap in time" if steps[k - 1] > period else "a sample closer than the period"
        raise ValueError(f"{recording.where(d, k, 't')}: time jumps from {t[k - 1]:g} to {t[k]:g} s but demonstration "
                         f"{recording.ids[d]!r} is sampled every {period:g} s ({what}); resample it regularly")
    ratio = dt / period
    if ratio < 1 - _TOLERANCE or abs(ratio - round(ratio)) > _TOLERANCE * ratio:
        raise ValueError(f"{recording.where(d, 1, 't')}: demonstration {recording.ids[d]!r} is sampled every "
                         f"{period:g} s, which does not divide the model's time step dt = {dt:g} s")
    return int(round(ratio))


def align(recording, dt, truncate=False):
    """``(states (N, L+1, n), controls (N, L, m) or None, sample index (N, L+1))``: every k-th sample so
    that steps are ``dt`` apart, controls averaged over each step. Demonstrations must span the
    same number of steps (``truncate``: cut them to the shortest)."""
    picks = []
    for d in range(len(recording)):
        k = _stride(recording, d, dt)
        picks.append((k, np.arange(0, recording.times[d].size, k)))
    lengths = [p.size for _, p in picks]
    if min(lengths) < 2:
        d = int(np.argmin(lengths))
        raise ValueError(f"{recording.where(d, 0, 't')}: demonstration {recording.ids[d]!r} is shorter than one "
                         f"step of dt = {dt:g} s")
    if len(set(lengths)) > 1 and not truncate:
        d = int(np.argmax(np.array(lengths) != lengths[0]))
        raise ValueError(f"{recording.where(d, 0, 't')}: demonstration {recording.ids[d]!r} spans {lengths[d] - 1} "
                         f"steps of dt = {dt:g} s, demonstration {recording.ids[0]!r} {lengths[0] - 1}; every "
                         "demonstration must span the same time (trim them, or truncate to the shortest)")
    L = min(lengths) - 1
    states = np.stack([recording.states[d][p[: L + 1]] for d, (_, p) in enumerate(picks)])
    index = np.stack([p[: L + 1] for _, p in picks])
    controls = None
    if recording.controls is not None:
        controls = np.stack([_step_controls(recording.controls[d], p, k, L) for d, (k, p) in enumerate(picks)])
    return states, controls, index


def _step_controls(C, picks, k, L):
    """(L, m): the mean of the fully recorded controls within each step, nan where there is none."""
    out = np.full((L, C.shape[1]), np.nan)
    for i in range(L):
        window = C[picks[i]: picks[i] + k]
        window = window[np.isfinite(window).all(axis=1)]
        if len(window):
            out[i] = window.mean(axis=0)
    return out


def check_plausible(problem, recording, states, controls, index):
    """What a user gets wrong in recordings that still read, for the aligned ``states`` (N, L+1, n), ``controls``
    (N, L, m) or None and sample ``index`` of :func:`align`: demonstrations longer than the horizon and time that
    runs backwards are refused; angles that look like degrees, recorded controls far outside the control set and
    recorded controls that do not explain the recorded motion are warned about (:class:`mutual.inputs.InputWarning`)."""
    L = states.shape[1] - 1
    if L > problem.horizon:
        raise ValueError(f"{recording.where(0, index[0, -1], 't')}: the demonstrations span {L} steps of dt = "
                         f"{problem.dt:g} s, more than the horizon T = {problem.horizon} of the system ([time] "
                         f"horizon); raise the horizon to at least {L}, or trim the recordings")
    grid = problem.grid
    for i in np.flatnonzero(grid.periodic):
        message = angle_unit_warning([s[:, i] for s in recording.states], f"{recording.source}, column "
                                     f"{grid.names[i]!r} (periodic, radians)", grid.low[i], grid.high[i],
                                     times=recording.times)
        if message:
            warn(message)
    if recording.controls is not None and not _check_control_range(problem, recording):
        _check_control_motion(problem, recording, states, controls)
    _check_time_direction(problem, recording, states)


def _check_control_range(problem, recording):
    """Warn about recorded controls more than the control set's width outside it (each is snapped to its edge);
    True if it warned."""
    names, warned = problem.system.control_names, False
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
            warned = True
    return warned


def _check_control_motion(problem, recording, states, controls, most=2000):
    """Warn when the recorded controls do not explain the recorded motion: on more than a quarter of the steps, a
    step taken with the recorded control misses the next state by more than twice the best control's miss and
    by more than a quarter of the spread between the set's predictions. A unit or sign mistake that stays
    inside the set (kN m for N m, a reversed sign) shows so; the least-squares factor between the best
    controls and the recorded ones names it, per control."""
    n, m = states.shape[2], controls.shape[2]
    x, nxt, u = states[:, :-1].reshape(-1, n), states[:, 1:].reshape(-1, n), controls.reshape(-1, m)
    recorded = np.flatnonzero(np.isfinite(u).all(axis=1))
    if recorded.size < 10:
        return
    pick = recorded[np.linspace(0, recorded.size - 1, min(most, recorded.size)).astype(int)]
    grid = problem.grid
    x, nxt, u = grid.wrap(x[pick]), grid.wrap(nxt[pick]), u[pick]
    own, miss = _distance(grid, problem.step(x, u), nxt), _misses(problem, x, nxt)
    best, spread = miss.min(axis=1), miss.max(axis=1) - miss.min(axis=1)
    wrong = own > np.maximum(np.maximum(2 * best, 0.25 * spread), 1e-6)
    if not wrong.mean() > 0.25:
        return
    names, fitted = problem.system.control_names, problem.controls[miss.argmin(axis=1)]
    factor = (fitted * u).sum(axis=0) / np.maximum((u * u).sum(axis=0), 1e-300)
    off = [f"{name!r} about {a:.4g} times the recorded one{' (its sign looks reversed)' if a < 0 else ''}"
           for name, a in zip(names, factor) if not 0.8 <= a <= 1.25]
    hint = ("the controls that explain the steps are " + ", ".join(off) + ": check the unit and the sign"
            if off else "check the system's [parameters] and that each row's control acts from its t to the next row's")
    where = f"column {names[0]!r}" if m == 1 else "columns " + ", ".join(map(repr, names))
    warn(f"{recording.source}, {where}: the recorded controls do not explain the recorded motion: on "
         f"{wrong.mean():.0%} of the steps a step with the recorded control misses the next state by "
         f"{np.median(own[wrong]):.3g} cell widths (median), a step with the best control of the set by "
         f"{np.median(best[wrong]):.2g}; {hint}")


def _distance(grid, a, b):
    """Distances (in cell widths, periodic coordinates the short way round) between states a (..., n) and b."""
    diff = a - b
    for i in np.flatnonzero(grid.periodic):
        period = grid.high[i] - grid.low[i]
        diff[..., i] = np.mod(diff[..., i] + period / 2, period) - period / 2
    scale = np.array([np.min(grid.widths_1d(i)) for i in range(grid.ndim)])
    return np.sqrt(((diff / scale) ** 2).sum(axis=-1))


def _misses(problem, x, nxt):
    """(k, A): each control's one-step prediction's distance from the states x (k, n) to nxt (k, n), in cell widths."""
    A = problem.n_actions
    pred = problem.step(np.repeat(x, A, axis=0), np.tile(problem.controls, (len(x), 1))).reshape(len(x), A, -1)
    return _distance(problem.grid, pred, nxt[:, None, :])


def _check_time_direction(problem, recording, states, most=2000):
    """Refuse recordings whose states, in the order of t, follow the dynamics backwards: each step's best one-step
    prediction misses the next state by more than half the step, while a step taken from the next state lands
    on the previous one (a quarter of that miss or nearer)."""
    n = states.shape[2]
    x, nxt = states[:, :-1].reshape(-1, n), states[:, 1:].reshape(-1, n)
    pick = np.linspace(0, len(x) - 1, min(most, len(x))).astype(int)
    x, nxt = problem.grid.wrap(x[pick]), problem.grid.wrap(nxt[pick])
    forward = float(np.median(_misses(problem, x, nxt).min(axis=1)))
    step = float(np.median(_distance(problem.grid, nxt, x)))
    if not forward > max(0.5 * step, 0.05):           # the dynamics explain the steps (or nothing moves)
        return
    backward = float(np.median(_misses(problem, nxt, x).min(axis=1)))
    if backward < 0.25 * forward:
        raise ValueError(f"{recording.source}, column 't': the recorded motion runs backwards in time: in the order "
                         f"of t, the dynamics' best one-step prediction misses the next state by {forward:.3g} cell "
                         f"widths (median; the steps are {step:.3g}), but a step from the next state lands "
                         f"{backward:.3g} from the previous one; t seems to decrease along the motion (a time-to-go, "
                         "or its sign): make t increase as the motion goes")
