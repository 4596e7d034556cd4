"""Misaligned expectations (Fig. 5.1, Sec. 4.5), SIMULATED: robots that detected an obstacle avoid
it on their own safe set while a noisy idealized supervisor (Sec. 4.3) watches.

A robot that ignores the supervisor's notion of safety (the Standard set, ``alpha = 0`` of the
true dynamics) turns late, leaves the supervisor's safe set ``{V_S >= mu}`` and draws an
intervention although it would have avoided the obstacle (a false positive). A robot that
follows the supervisor's safe set (its own member at ``alpha = mu``) turns where the supervisor
expects it to, and draws interventions only when the supervisor's judgement noise pushes their
level above ``mu``.
"""

import numpy as np

from ..supervision import SPEED, TRUE_W_MAX, NoisySupervisor, ValueFunction, safety_controller, simulate_filtered


def straight_approach_starts(n, rng, start_distance=7.0, spread=0.6):
    """``n`` robots ``start_distance`` left of the obstacle centre, heading right (theta = 0), with
    lateral offsets uniform in ``[-spread, spread]`` (obstacle radii)."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    for name, v in (("start_distance", start_distance), ("spread", spread)):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.number)) or not np.isfinite(v) or v < 0:
            raise ValueError(f"{name} must be a non-negative finite number, got {v!r}")
    y = rng.uniform(-spread, spread, n)
    return np.stack([np.full(n, -float(start_distance)), y, np.zeros(n)], axis=1)


def supervised_approaches(team_value, alpha, supervisor, starts, rng, dt=0.02):
    """Robots from ``starts`` (n, 3) that have detected the obstacle drive straight at it under the
    minimally invasive controller on ``{team_value >= alpha}`` (Sec. 4.2, 4.5; turn rate the
    model's, at most the robots' true 1 rad/s, one step of lookahead) until they are as far past
    it as they started. The ``supervisor`` judges each approach once (level ``mu - w``) and
    intervenes at the first state with ``V_S <= level``: every intervention is a false positive.

    Returns a dict: ``paths`` (n, T, 3), ``intervened`` (n,) bool, ``interventions`` (m, 3) states
    and ``closest`` (the smallest distance from the obstacle's edge over all paths).
    """
    if not isinstance(team_value, ValueFunction):
        raise ValueError(f"team_value must be a ValueFunction, got {type(team_value).__name__}")
    if not isinstance(supervisor, NoisySupervisor):
        raise ValueError(f"supervisor must be a NoisySupervisor, got {type(supervisor).__name__}")
    controller = safety_controller(team_value, alpha, u_max=min(team_value.w_max, TRUE_W_MAX), lookahead=dt)
    starts = np.asarray(starts, dtype=float)
    if starts.ndim != 2 or starts.shape[1] != 3 or len(starts) == 0 or not np.isfinite(starts).all():
        raise ValueError(f"starts must be a finite (n, 3) array of (x, y, theta), got shape {starts.shape}")
    duration = 2 * float(np.max(np.hypot(starts[:, 0], starts[:, 1]))) / SPEED
    paths = np.swapaxes(simulate_filtered(controller, starts, 0.0, duration, dt), 0, 1)
    points, which = supervisor.first_interventions(paths, rng)
    intervened = np.zeros(len(paths), bool)
    intervened[which] = True
    closest = float(np.min(np.hypot(paths[..., 0], paths[..., 1])) - team_value.obstacle_radius)
    return {"paths": paths, "intervened": intervened, "interventions": points, "closest": closest}
