"""One time step of a batch of SIMULATED Phase III trials (Sec. 5.2; :func:`mutual.study.teaming.simulate_teaming`):
the robots drive (nominal steering, overridden by the minimally invasive avoid control of Sec. 4.2, 4.5), the
noisy supervisor of Sec. 4.3 judges and removes obstacles, and trips end in arrivals or collisions.

The batch's state is kept by coordinate, (B, R) robots and (B, O) obstacles for B trials, and every
robot-obstacle pair is a (B, R, O) array. Values are interpolated only where they can change what happens:
pairs within reach of a value below the level in question (:meth:`~.value_stack._Stack.reach`) and on the
grid, and distances (hypot) only where they can be below the threshold in question; every other number is
computed as a whole batch computes it, the random streams are drawn in the same order and sizes, and so the
counts are the same, bit for bit, as those of evaluating every pair.
"""

from dataclasses import dataclass

import numpy as np

from ..supervision import TRUE_W_MAX, dubins_arc, wrap_angle
from .value_stack import REACH_SLACK


def _candidates(rng, config, n):
    r = config.obstacle_radius
    return rng.uniform([config.depot_clearance, 2 * r], [config.width - config.depot_clearance, config.height - 2 * r],
                       size=(n, 2))


def _relocate(candidates, others, robots, config):
    """New centres for removed obstacles, one per row: of the row's random ``candidates`` (k, 64, 2), those
    ``obstacle_gap`` clear of the ``others`` (k, O - 1, 2) obstacles of its trial (or the clearest, if none
    is), the one farthest from every robot (k, R, 2) of its trial."""
    gap = np.min(np.linalg.norm(candidates[:, :, None] - others[:, None], axis=3), axis=2)
    clear = gap >= config.obstacle_gap
    far = np.min(np.linalg.norm(candidates[:, :, None] - robots[:, None], axis=3), axis=2)
    best = np.where(clear.any(axis=1), np.argmax(np.where(clear, far, -np.inf), axis=1), np.argmax(gap, axis=1))
    return candidates[np.arange(len(best)), best]


@dataclass
class _Batch:
    """The mutable state of a batch of Phase III trials (B trials, R robots, O obstacles), by coordinate."""
    x: np.ndarray               # (B, R) robot positions and headings (world frame)
    y: np.ndarray
    theta: np.ndarray
    ox: np.ndarray              # (B, O) obstacle centres
    oy: np.ndarray
    goal_x: np.ndarray          # (B, R) depot the robot is heading for
    goal_y: np.ndarray          # (B, R)
    origin_x: np.ndarray        # (B, R) depot it left
    detected: np.ndarray        # (B, R, O) this trip's detections
    threshold: np.ndarray       # (B, R, O) supervisor's judgement level for the current approach
    was_near: np.ndarray        # (B, R, O)
    placed_inside: np.ndarray   # (B, R, O) the obstacle reappeared with the robot already inside {V_S < mu}
                                # (None unless the unavoidable false positives are asked for)
    latched: np.ndarray         # (B, R) obstacle being avoided, or -1
    turn: np.ndarray            # (B, R) the avoid control while latched
    counts: dict
    # within a step, from _drive to _end_trips: the robots' positions minus the obstacles' (dx, dy, and
    # dx^2 + dy^2; (B, R, O)), the pairs close enough to matter to _end_trips and those of moved obstacles
    dx: np.ndarray = None
    dy: np.ndarray = None
    d2: np.ndarray = None
    close: np.ndarray = None
    moved: np.ndarray = None


def _start_batch(versions, layouts, config, rng, details):
    """The batch at time 0: ``layouts[v]`` is task version ``v``'s (obstacles, robots)."""
    robots = np.stack([layouts[v][1] for v in versions]).astype(float)
    obstacles = np.stack([layouts[v][0] for v in versions])
    n, R, O = len(versions), config.n_robots, config.n_obstacles
    goal_x = np.where(robots[..., 0] == 0.0, config.width, 0.0)
    return _Batch(x=robots[..., 0].copy(), y=robots[..., 1].copy(), theta=robots[..., 2].copy(),
                  ox=obstacles[..., 0].copy(), oy=obstacles[..., 1].copy(), goal_x=goal_x,
                  goal_y=rng.uniform(2.0, config.height - 2.0, (n, R)), origin_x=config.width - goal_x,
                  detected=rng.random((n, R, O)) < config.detection_prob, threshold=np.full((n, R, O), -np.inf),
                  was_near=np.zeros((n, R, O), bool), placed_inside=np.zeros((n, R, O), bool) if details else None,
                  latched=np.full((n, R), -1), turn=np.zeros((n, R)),
                  counts={k: np.zeros(n, int) for k in ("trips", "interventions", "collisions", "false_positives",
                                                        "unavoidable_false_positives",
                                                        "encounters", "detected_encounters")})


def _drive(b, teams, config):
    """Nominal steering to the goal, overridden by the minimally invasive avoid control (Sec. 4.2, 4.5).

    Detected obstacles only: a robot engages when its nominal next state would leave
    ``{V_team >= alpha + margin}``, then turns at the optimal control's sign until it stops
    approaching that obstacle (it has cleared it); turn rates are clipped to the true ``w_max``.
    Values are computed only where they can matter: detected obstacles whose grid holds the next state.
    """
    stack, alpha, teams_reach = teams
    B, R, O = b.detected.shape
    bearing = np.arctan2(b.goal_y - b.y, b.goal_x - b.x)
    u = np.minimum(np.maximum(config.heading_gain * wrap_angle(bearing - b.theta), -TRUE_W_MAX), TRUE_W_MAX)
    x, y, theta = dubins_arc(b.x, b.y, b.theta, u, config.dt)
    dx, dy = x[:, :, None] - b.ox[:, None, :], y[:, :, None] - b.oy[:, None, :]
    d2 = dx * dx + dy * dy
    # V_team - alpha - margin < 0 only within reach of a detected obstacle, on its grid: the values elsewhere
    # cannot make a robot engage, nor be the lowest of a robot that does
    reach = teams_reach[:, None, None]
    pairs = np.flatnonzero(b.detected & (d2 <= reach * np.abs(reach)))     # reach -1: nowhere
    w = stack.half_width
    pairs = pairs[(np.abs(dx.ravel()[pairs]) <= w) & (np.abs(dy.ravel()[pairs]) <= w)]
    trial = pairs // (R * O)
    v_next = (stack.on_grid(dx.ravel()[pairs], dy.ravel()[pairs], theta.ravel()[pairs // O], trial)
              - alpha[trial] - config.filter_margin)
    robot = pairs // O
    low = np.unique(robot[v_next < 0])            # robots whose next state leaves a detected obstacle's safe set
    engage = np.zeros((B, R), bool)
    worst = np.zeros((B, R), int)
    if len(low):
        table = np.full((len(low), O), np.inf)
        mine = np.isin(robot, low)
        table[np.searchsorted(low, robot[mine]), pairs[mine] % O] = v_next[mine]
        worst.ravel()[low] = np.argmin(table, axis=1)
        engage.ravel()[low] = b.latched.ravel()[low] != worst.ravel()[low]
    if engage.any():
        bi, ri = np.nonzero(engage)
        o = worst[bi, ri]
        slope = stack.values_at(b.x[bi, ri] - b.ox[bi, o], b.y[bi, ri] - b.oy[bi, o], b.theta[bi, ri], bi,
                                fill_value=0.0, derivative=True)
        # the optimal avoid control u* = w sign(dV/dtheta) of the team's model, clipped to the robots' turn rate
        w_model = np.minimum(stack.w_max[bi], TRUE_W_MAX)
        b.turn[bi, ri] = np.where(slope >= 0, w_model, -w_model)
        b.latched[bi, ri] = o
    bi, ri = np.nonzero(b.latched >= 0)
    if len(bi):     # latched robots turn at their avoid control instead: their states and offsets anew
        x[bi, ri], y[bi, ri], theta[bi, ri] = dubins_arc(b.x[bi, ri], b.y[bi, ri], b.theta[bi, ri], b.turn[bi, ri],
                                                         config.dt)
        dx[bi, ri], dy[bi, ri] = x[bi, ri][:, None] - b.ox[bi], y[bi, ri][:, None] - b.oy[bi]
        d2[bi, ri] = dx[bi, ri] * dx[bi, ri] + dy[bi, ri] * dy[bi, ri]
    b.x, b.y, b.theta, b.dx, b.dy, b.d2 = x, y, theta, dx, dy, d2
    if len(bi):     # released once no longer approaching the obstacle it avoids
        o = b.latched[bi, ri]
        along = (x[bi, ri] - b.ox[bi, o]) * np.cos(theta[bi, ri]) + (y[bi, ri] - b.oy[bi, o]) * np.sin(theta[bi, ri])
        cleared = ~(along < 0)
        b.latched[bi[cleared], ri[cleared]] = -1


def _supervise(b, sups, config, rng):
    """The noisy idealized supervisor (Sec. 4.3): a fresh judgement level ``mu - w`` whenever a robot
    comes within ``near_distance`` of an obstacle; remove (relocate) the obstacle when a near robot
    reaches ``V_S <= level``. Returns the (trial, obstacle) pairs removed."""
    stack, mu, sigma = sups
    B, R, O = b.detected.shape
    # hypot(dx, dy) <= d needs dx^2 + dy^2 <= d^2 (to round-off): hypot only there, for the supervisor's
    # near pairs and _end_trips's collisions
    within = max(config.near_distance, config.obstacle_radius) + REACH_SLACK
    b.close = np.flatnonzero(b.d2 <= within * within)
    b.moved = b.close[:0]
    pairs = b.close[np.hypot(b.dx.ravel()[b.close], b.dy.ravel()[b.close]) <= config.near_distance]
    near = np.zeros(B * R * O, bool)
    near[pairs] = True
    fresh = pairs[~b.was_near.ravel()[pairs]]
    if len(fresh):
        draw = rng.standard_normal(b.detected.shape).ravel()     # one draw per pair, as for every pair
        trial = fresh // (R * O)
        b.threshold.ravel()[fresh] = mu[trial] - sigma[trial] * draw[fresh]
        b.counts["encounters"] += np.bincount(trial, minlength=B)
        b.counts["detected_encounters"] += np.bincount(trial[b.detected.ravel()[fresh]], minlength=B)
    near = near.reshape(B, R, O)
    b.was_near = near
    if b.placed_inside is not None:
        b.placed_inside &= near
    trial = pairs // (R * O)
    values = stack.values_at(b.dx.ravel()[pairs], b.dy.ravel()[pairs], b.theta.ravel()[pairs // O], trial)
    trigger = pairs[values <= b.threshold.ravel()[pairs]]
    key = np.unique(trigger // (R * O) * O + trigger % O)
    if len(key):
        _remove(b, key // O, key % O, near, stack, mu, config, rng)
    return list(zip(key // O, key % O))


def _remove(b, t, o, near, stack, mu, config, rng):
    """The supervisor removes obstacle ``o[i]`` of trial ``t[i]`` (in (trial, obstacle) order): count the
    intervention (a false positive when every robot near it had detected it), then relocate the obstacle with
    fresh detections, one removal after another (an obstacle moved earlier in a trial is one of the others
    for the next); mark the robots already inside the supervisor's unsafe set around its new place."""
    B, R, O = b.detected.shape
    involved = near[t, :, o]
    false_positive = np.all(b.detected[t, :, o] | ~involved, axis=1)
    b.counts["interventions"] += np.bincount(t, minlength=B)
    b.counts["false_positives"] += np.bincount(t[false_positive], minlength=B)
    if b.placed_inside is not None:
        unavoidable = false_positive & np.any(b.placed_inside[t, :, o] & involved, axis=1)
        b.counts["unavoidable_false_positives"] += np.bincount(t[unavoidable], minlength=B)
    draws = [(_candidates(rng, config, 64), rng.random(R)) for _ in t]     # the random stream, removal by removal
    candidates = np.stack([c for c, _ in draws])
    b.detected[t, :, o] = np.stack([d for _, d in draws]) < config.detection_prob
    rank = np.arange(len(t)) - np.searchsorted(t, t)                      # the removal's place within its trial
    for k in range(rank.max() + 1):
        tk, ok = t[rank == k], o[rank == k]
        centres = np.stack([b.ox[tk], b.oy[tk]], axis=2)
        others = centres[np.arange(O) != ok[:, None]].reshape(len(tk), O - 1, 2)
        b.ox[tk, ok], b.oy[tk, ok] = _relocate(candidates[rank == k], others,
                                               np.stack([b.x[tk], b.y[tk]], axis=2), config).T
    b.was_near[t, :, o] = False
    gone = np.zeros((B, O), bool)
    gone[t, o] = True
    b.latched[(b.latched >= 0) & gone[np.arange(B)[:, None], np.maximum(b.latched, 0)]] = -1
    b.dx[t, :, o], b.dy[t, :, o] = b.x[t] - b.ox[t, o][:, None], b.y[t] - b.oy[t, o][:, None]
    b.moved = ((t * R)[:, None] + np.arange(R)) * O + o[:, None]
    if b.placed_inside is not None:
        rows = np.broadcast_to(t[:, None], (len(t), R))
        b.placed_inside[t, :, o] = stack.values_at(b.dx[t, :, o], b.dy[t, :, o], b.theta[t], rows) < mu[t][:, None]


def _end_trips(b, config, rng):
    """Collisions restart a trip from its depot, arrivals complete it; both draw a new goal and detections."""
    B, R, O = b.detected.shape
    crashed = np.zeros(B * R, bool)
    near = np.concatenate([b.close, b.moved.ravel()])       # every pair that can be within the radius
    crashed[near[np.hypot(b.dx.ravel()[near], b.dy.ravel()[near]) < config.obstacle_radius] // O] = True
    crashed = crashed.reshape(B, R)
    arrived = (np.abs(b.x - b.goal_x) < config.goal_tolerance) & ~crashed
    b.counts["collisions"] += crashed.sum(axis=1)
    b.counts["trips"] += arrived.sum(axis=1)
    if crashed.any():
        b.x[crashed] = b.origin_x[crashed]
        b.y[crashed] = rng.uniform(2.0, config.height - 2.0, crashed.sum())
        b.theta[crashed] = np.where(b.goal_x[crashed] > b.origin_x[crashed], 0.0, np.pi)
    b.goal_x, b.origin_x = np.where(arrived, b.origin_x, b.goal_x), np.where(arrived, b.goal_x, b.origin_x)
    renew = crashed | arrived
    if renew.any():
        b.goal_y = np.where(renew, rng.uniform(2.0, config.height - 2.0, renew.shape), b.goal_y)
        b.detected = np.where(renew[..., None], rng.random(b.detected.shape) < config.detection_prob, b.detected)
        b.was_near &= ~renew[..., None]
        b.latched = np.where(renew, -1, b.latched)
