"""What a user gets wrong in recordings that still read (:func:`check_plausible`): refused or warned about.

Refused: demonstrations longer than the horizon; time that runs backwards (the states follow the dynamics
backwards). Warned about (:class:`mutual.inputs.InputWarning`): periodic angles that look like degrees (the
dynamics decide where they can); recorded controls far outside the control set; recorded controls that do not
explain the recorded motion (a unit, a sign, exchanged columns, a shift by one row, or zeros for missing values),
in the whole file or in the demonstrations that stand out; demonstrations that reach the edge of the box.
Distances between states are in cell widths (periodic coordinates the short way).
"""

import numpy as np

from ...inputs import angle_unit_warning, warn
from .controlcheck import check_control_motion
from .misses import distance, mean_miss, narrowest, recorded_steps, spread, step_misses


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
            check_control_motion(problem, recording, states, controls)
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
        return mean_miss(problem, states, controls)
    except ValueError:
        return np.inf


def _as_degrees(problem, states, i, most=2000):
    """``(as recorded, as degrees)``: the mean squared miss (cell widths) of the best control's step over up to
    ``most`` recorded steps (spread), with the periodic coordinate ``i`` as recorded and read as degrees (times
    pi/180, its miss still counted in recorded units); None where the dynamics fail."""
    n = states.shape[2]
    x, nxt = states[:, :-1].reshape(-1, n), states[:, 1:].reshape(-1, n)
    pick = spread(len(x), most)
    x, nxt = x[pick], nxt[pick]
    radians, widths = np.where(np.arange(n) == i, np.pi / 180, 1.0), narrowest(problem.grid)

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


def _check_time_direction(problem, recording, states, most=2000):
    """Refuse recordings whose states, in the order of t, follow the dynamics backwards: each step's best one-step
    prediction misses the next state by more than half the step, while a step taken from the next state lands
    on the previous one (a quarter of that miss or nearer)."""
    x, nxt, _ = recorded_steps(problem, states)
    pick = spread(len(x), most)
    x, nxt = x[pick], nxt[pick]
    forward = float(np.median(step_misses(problem, x, nxt).min(axis=1)))
    step = float(np.median(distance(problem.grid, nxt, x)))
    if not forward > max(0.5 * step, 0.05):           # the dynamics explain the steps (or nothing moves)
        return
    backward = float(np.median(step_misses(problem, nxt, x).min(axis=1)))
    if backward < 0.25 * forward:
        raise ValueError(f"{recording.source}, column 't': the recorded motion runs backwards in time: in the order "
                         f"of t, the dynamics' best one-step prediction misses the next state by {forward:.3g} cell "
                         f"widths (median; the steps are {step:.3g}), but a step from the next state lands "
                         f"{backward:.3g} from the previous one; t seems to decrease along the motion (a time-to-go, "
                         "or its sign): make t increase as the motion goes")
