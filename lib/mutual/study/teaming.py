"""SIMULATED Phase III of the chapter 5 user study (the teaming task, Fig. 5.3, Sec. 5.2.3).

Robots shuttle between depots on the left and right edges of a workspace with disk obstacles. On
every trip each robot detects each obstacle with probability 0.8; detected obstacles are avoided
with the minimally invasive controller on the team's safe set (nominal steering to the goal unless
the next state would leave ``{V_team >= alpha}``, then the optimal avoid control
``u* = w sign(dV/dtheta)``, Sec. 4.2); undetected ones are driven into. The simulated supervisor
removes (relocates) an obstacle when a robot near it reaches ``V_S + w <= mu`` (a fresh ``w`` per
approach). Counted per trial: trips, interventions, collisions, false positives (interventions
where every robot near the obstacle had detected it, so would have avoided it) and the arcade score
(trip +1, collision -1, removal -1/2; Sec. 5.2.3). Everything is vectorized over trials, robots
and obstacles; a study's trials run as one batch.
"""

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..supervision.dubins import TRUE_W_MAX, dubins_step, wrap_angle
from ..supervision.reachability import ValueFunction
from ..supervision.supervisor import NoisySupervisor
from .design import OBSTACLE_RADIUS
from .value_stack import _Stack, _unique


@dataclass(frozen=True, repr=False)
class Team:
    """A robot team's safe set ``{V >= alpha}`` used by the minimally invasive controller."""
    value: ValueFunction
    alpha: float = 0.0

    def __post_init__(self):
        if not isinstance(self.value, ValueFunction):
            raise ValueError("value must be a mutual.supervision.reachability.ValueFunction")
        if isinstance(self.alpha, bool) or not isinstance(self.alpha, (int, float, np.number)) \
                or not np.isfinite(self.alpha):
            raise ValueError(f"alpha must be a finite number, got {self.alpha!r}")

    def __repr__(self):
        return (f"Team(safe set V >= {self.alpha:.3g} of the Dubins model w_max={self.value.w_max:g}, "
                f"obstacle radius {self.value.obstacle_radius:g})")


@dataclass(frozen=True)
class TeamingConfig:
    """Phase III task. The thesis gives only the detection probability and the score rule; the
    rest are our choices (workspace in units of the Dubins speed 3/s, obstacle radius 1).
    ``filter_margin``: the controller engages when the next state would fall below
    ``alpha + filter_margin`` (0 as in the thesis; a margin of about the grid value function's
    error keeps robots inside ``{V >= alpha}`` exactly in discrete time)."""
    width: float = 40.0
    height: float = 24.0
    obstacle_radius: float = OBSTACLE_RADIUS
    n_robots: int = 5
    n_obstacles: int = 8
    duration: float = 60.0
    dt: float = 0.05
    detection_prob: float = 0.8
    near_distance: float = 6.0
    goal_tolerance: float = 1.0
    heading_gain: float = 2.0
    depot_clearance: float = 8.0
    obstacle_gap: float = 6.0
    filter_margin: float = 0.0
    trip_reward: float = 1.0
    collision_cost: float = 1.0
    removal_cost: float = 0.5

    def __post_init__(self):
        def number(name):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.number)) or not np.isfinite(v):
                raise ValueError(f"{name} must be a finite number, got {v!r}")
            return v
        for name in ("width", "height", "obstacle_radius", "duration", "dt", "near_distance", "goal_tolerance",
                     "heading_gain"):
            if not number(name) > 0:
                raise ValueError(f"{name} must be a positive number, got {getattr(self, name)!r}")
        for name in ("depot_clearance", "obstacle_gap", "filter_margin", "trip_reward", "collision_cost",
                     "removal_cost"):
            if number(name) < 0:
                raise ValueError(f"{name} must be a non-negative number, got {getattr(self, name)!r}")
        for name in ("n_robots", "n_obstacles"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"{name} must be a positive integer, got {v!r}")
        if not 0 <= number("detection_prob") <= 1:
            raise ValueError(f"detection_prob must lie in [0, 1], got {self.detection_prob!r}")
        if self.width <= 2 * self.depot_clearance:
            raise ValueError("width must exceed twice depot_clearance")


@dataclass(repr=False)
class TeamingRecord:
    """Snapshots of one trial (for Fig. 5.3): robot states, obstacle centres, detections, times."""
    times: list = field(default_factory=list)
    robots: list = field(default_factory=list)
    obstacles: list = field(default_factory=list)
    detected: list = field(default_factory=list)
    removals: list = field(default_factory=list)

    def __repr__(self):
        span = f"{self.times[0]:g}-{self.times[-1]:g} s" if self.times else "empty"
        robots = len(self.robots[0]) if self.robots else 0
        return f"TeamingRecord({len(self.times)} snapshots, {span}, {robots} robots, {len(self.removals)} removals)"


def task_layout(version, config):
    """Obstacle centres and robot start states of task ``version`` (a seeded random layout).

    Obstacles are placed uniformly in the middle of the workspace (``depot_clearance`` from
    each depot), at least ``obstacle_gap`` apart; robots start on alternating depots.
    """
    if isinstance(version, bool) or not isinstance(version, (int, np.integer)) or version < 0:
        raise ValueError(f"version must be a non-negative whole number (a task version), got {version!r}")
    if not isinstance(config, TeamingConfig):
        raise ValueError(f"config must be a TeamingConfig, got {type(config).__name__}")
    rng = np.random.default_rng([20_19, int(version)])
    obstacles = _free_positions(rng, config, config.n_obstacles)
    side = np.arange(config.n_robots) % 2
    x = np.where(side == 0, 0.0, config.width)
    y = rng.uniform(2.0, config.height - 2.0, config.n_robots)
    robots = np.stack([x, y, np.where(side == 0, 0.0, np.pi)], axis=1)
    return obstacles, robots


def _free_positions(rng, config, n):
    """``n`` obstacle centres in the middle of the workspace, ``obstacle_gap`` apart (rejection sampling)."""
    out = np.empty((0, 2))
    for _ in range(100):
        c = _candidates(rng, config, 1)[0]
        if len(out) == 0 or np.min(np.linalg.norm(out - c, axis=1)) >= config.obstacle_gap:
            out = np.vstack([out, c])
            if len(out) == n:
                return out
    raise ValueError("could not place the obstacles: lower n_obstacles or obstacle_gap, or enlarge the workspace")


def _candidates(rng, config, n):
    r = config.obstacle_radius
    return rng.uniform([config.depot_clearance, 2 * r], [config.width - config.depot_clearance, config.height - 2 * r],
                       size=(n, 2))


def _relocate(rng, config, others, robots):
    """A new centre for a removed obstacle: of 64 random candidates ``obstacle_gap`` clear of the
    other obstacles (or the clearest, if none is), the one farthest from every robot."""
    cand = _candidates(rng, config, 64)
    gap = np.min(np.linalg.norm(cand[:, None] - others[None], axis=2), axis=1)
    clear = gap >= config.obstacle_gap
    pool = cand[clear] if clear.any() else cand[[np.argmax(gap)]]
    far = np.min(np.linalg.norm(pool[:, None] - robots[None], axis=2), axis=1)
    return pool[np.argmax(far)]


@dataclass
class _Batch:
    """The mutable state of a batch of Phase III trials (B trials, R robots, O obstacles)."""
    robots: np.ndarray          # (B, R, 3) world states
    obs: np.ndarray             # (B, O, 2) obstacle centres
    goal_x: np.ndarray          # (B, R) depot the robot is heading for
    goal_y: np.ndarray          # (B, R)
    origin_x: np.ndarray        # (B, R) depot it left
    detected: np.ndarray        # (B, R, O) this trip's detections
    threshold: np.ndarray       # (B, R, O) supervisor's judgement level for the current approach
    was_near: np.ndarray        # (B, R, O)
    placed_inside: np.ndarray   # (B, R, O) the obstacle reappeared with the robot already inside {V_S < mu}
    latched: np.ndarray         # (B, R) obstacle being avoided, or -1
    turn: np.ndarray            # (B, R) the avoid control while latched
    counts: dict


def _start_batch(versions, config, rng):
    layouts = [task_layout(v, config) for v in versions]
    robots = np.stack([l[1] for l in layouts]).astype(float)
    n, R, O = len(versions), config.n_robots, config.n_obstacles
    goal_x = np.where(robots[..., 0] == 0.0, config.width, 0.0)
    return _Batch(robots=robots, obs=np.stack([l[0] for l in layouts]), goal_x=goal_x,
                  goal_y=rng.uniform(2.0, config.height - 2.0, (n, R)), origin_x=config.width - goal_x,
                  detected=rng.random((n, R, O)) < config.detection_prob, threshold=np.full((n, R, O), -np.inf),
                  was_near=np.zeros((n, R, O), bool), placed_inside=np.zeros((n, R, O), bool),
                  latched=np.full((n, R), -1), turn=np.zeros((n, R)),
                  counts={k: np.zeros(n, int) for k in ("trips", "interventions", "collisions", "false_positives",
                                                        "unavoidable_false_positives",
                                                        "encounters", "detected_encounters")})


def _drive(b, teams, config):
    """Nominal steering to the goal, overridden by the minimally invasive avoid control (Sec. 4.2, 4.5).

    Detected obstacles only: a robot engages when its nominal next state would leave
    ``{V_team >= alpha + margin}``, then turns at the optimal control's sign until it stops
    approaching that obstacle (it has cleared it); turn rates are clipped to the true ``w_max``.
    """
    stack, alpha = teams
    n, R, _ = b.robots.shape
    bearing = np.arctan2(b.goal_y - b.robots[..., 1], b.goal_x - b.robots[..., 0])
    u = np.clip(config.heading_gain * wrap_angle(bearing - b.robots[..., 2]), -TRUE_W_MAX, TRUE_W_MAX)
    nxt = dubins_step(b.robots.reshape(-1, 3), u.ravel(), config.dt).reshape(n, R, 3)
    v_next = stack.interp(_relative(nxt, b.obs)) - alpha - config.filter_margin
    v_next = np.where(b.detected, v_next, np.inf)
    worst = np.argmin(v_next, axis=2)
    engage = (np.take_along_axis(v_next, worst[..., None], 2)[..., 0] < 0) & (b.latched != worst)
    if engage.any():
        bi, ri = np.nonzero(engage)
        rel_now = np.concatenate([b.robots[bi, ri, :2] - b.obs[bi, worst[bi, ri]], b.robots[bi, ri, 2:]], axis=1)
        slope = stack.interp(rel_now, fill_value=0.0, derivative=True, rows=bi)
        # the optimal avoid control u* = w sign(dV/dtheta) of the team's model, clipped to the robots' turn rate
        w_model = np.minimum(stack.w_max[bi], TRUE_W_MAX)
        b.turn[bi, ri] = np.where(slope >= 0, w_model, -w_model)
        b.latched[bi, ri] = worst[bi, ri]
    if (b.latched >= 0).any():
        nxt = dubins_step(b.robots.reshape(-1, 3), np.where(b.latched >= 0, b.turn, u).ravel(),
                          config.dt).reshape(n, R, 3)
    b.robots = nxt
    if (b.latched >= 0).any():
        held = b.robots[..., :2] - np.take_along_axis(b.obs, np.maximum(b.latched, 0)[..., None], 1)
        approaching = held[..., 0] * np.cos(b.robots[..., 2]) + held[..., 1] * np.sin(b.robots[..., 2]) < 0
        b.latched = np.where(approaching, b.latched, -1)


def _supervise(b, sups, config, rng):
    """The noisy idealized supervisor (Sec. 4.3): a fresh judgement level ``mu - w`` whenever a robot
    comes within ``near_distance`` of an obstacle; remove (relocate) the obstacle when a near robot
    reaches ``V_S <= level``. Returns the (trial, obstacle) pairs removed."""
    stack, mu, sigma = sups
    rel = _relative(b.robots, b.obs)
    near = np.hypot(rel[..., 0], rel[..., 1]) <= config.near_distance
    fresh = near & ~b.was_near
    if fresh.any():
        b.threshold = np.where(fresh, mu - sigma * rng.standard_normal(fresh.shape), b.threshold)
        b.counts["encounters"] += fresh.sum(axis=(1, 2))
        b.counts["detected_encounters"] += (fresh & b.detected).sum(axis=(1, 2))
    b.was_near = near
    b.placed_inside &= near
    trigger = near & (stack.interp(rel) <= b.threshold)
    removed = list(zip(*np.nonzero(trigger.any(axis=1))))
    for t, o in removed:
        involved = near[t, :, o] | trigger[t, :, o]
        false_positive = bool(np.all(b.detected[t, involved, o]))
        b.counts["interventions"][t] += 1
        b.counts["false_positives"][t] += false_positive
        b.counts["unavoidable_false_positives"][t] += false_positive and bool(b.placed_inside[t, involved, o].any())
        b.obs[t, o] = _relocate(rng, config, np.delete(b.obs[t], o, axis=0), b.robots[t, :, :2])
        b.detected[t, :, o] = rng.random(b.detected.shape[1]) < config.detection_prob
        b.was_near[t, :, o] = False
        b.latched[t, b.latched[t] == o] = -1
        moved = _relative(b.robots[t:t + 1], b.obs[t:t + 1, o:o + 1])[0, :, 0]
        b.placed_inside[t, :, o] = stack.interp(moved[None], rows=np.array([t]))[0] < mu[t, 0, 0]
    return removed


def _end_trips(b, config, rng):
    """Collisions restart a trip from its depot, arrivals complete it; both draw a new goal and detections."""
    gap = b.robots[:, :, None, :2] - b.obs[:, None, :, :]
    crashed = np.any(np.hypot(gap[..., 0], gap[..., 1]) < config.obstacle_radius, axis=2)
    arrived = (np.abs(b.robots[..., 0] - b.goal_x) < config.goal_tolerance) & ~crashed
    b.counts["collisions"] += crashed.sum(axis=1)
    b.counts["trips"] += arrived.sum(axis=1)
    if crashed.any():
        b.robots[crashed] = np.stack([b.origin_x[crashed], rng.uniform(2.0, config.height - 2.0, crashed.sum()),
                                      np.where(b.goal_x[crashed] > b.origin_x[crashed], 0.0, np.pi)], axis=1)
    b.goal_x, b.origin_x = np.where(arrived, b.origin_x, b.goal_x), np.where(arrived, b.goal_x, b.origin_x)
    renew = crashed | arrived
    if renew.any():
        b.goal_y = np.where(renew, rng.uniform(2.0, config.height - 2.0, renew.shape), b.goal_y)
        b.detected = np.where(renew[..., None], rng.random(b.detected.shape) < config.detection_prob, b.detected)
        b.was_near &= ~renew[..., None]
        b.latched = np.where(renew, -1, b.latched)


def simulate_teaming(teams, supervisors, versions, config=TeamingConfig(), seed=0, record=None, details=False):
    """Run a batch of Phase III trials (one per ``teams[i]``, ``supervisors[i]``, ``versions[i]``).

    Returns a DataFrame with one row per trial and columns trips, interventions, collisions,
    false_positives, score, and encounters / detected_encounters (robot-obstacle approaches
    within ``near_distance``, and those with the obstacle detected); with ``record=i`` also a
    :class:`TeamingRecord` of trial ``i``. With ``details`` also ``unavoidable_false_positives``: false
    positives on an obstacle that reappeared (after a removal) with a robot already inside the supervisor's
    unsafe set ``{V_S < mu}``, which no controller could have avoided (the Property's premise fails there).
    """
    teams, supervisors, versions = list(teams), list(supervisors), list(versions)
    n = len(teams)
    if n == 0 or len(supervisors) != n or len(versions) != n:
        raise ValueError(f"teams, supervisors and versions must be non-empty and equally long, "
                         f"got {len(teams)}, {len(supervisors)}, {len(versions)}")
    bad = next((i for i, t in enumerate(teams) if not isinstance(t, Team)), None)
    if bad is not None:
        raise ValueError(f"teams[{bad}] must be a Team, got {type(teams[bad]).__name__}")
    bad = next((i for i, s in enumerate(supervisors) if not isinstance(s, NoisySupervisor)), None)
    if bad is not None:
        raise ValueError(f"supervisors[{bad}] must be a NoisySupervisor, got {type(supervisors[bad]).__name__}")
    bad = next((i for i, v in enumerate(versions) if isinstance(v, bool) or not isinstance(v, (int, np.integer))), None)
    if bad is not None:
        raise ValueError(f"versions[{bad}] must be a whole number (a task version), got {versions[bad]!r}")
    if not isinstance(config, TeamingConfig):
        raise ValueError(f"config must be a TeamingConfig, got {type(config).__name__}")
    if record is not None and (isinstance(record, bool) or not isinstance(record, (int, np.integer))
                               or not 0 <= record < n):
        raise ValueError(f"record must index a trial (0..{n - 1}), got {record!r}")
    rng = np.random.default_rng(seed)
    b = _start_batch(versions, config, rng)
    team_stack = _Stack(*_unique([t.value for t in teams]), "team")
    team_stack.w_max = np.array([t.value.w_max for t in teams])
    sup_stack = _Stack(*_unique([s.value_fn for s in supervisors]), "supervisor")
    col = lambda values: np.array(values, dtype=float)[:, None, None]
    team_args = (team_stack, col([t.alpha for t in teams]))
    sup_args = (sup_stack, col([s.mu for s in supervisors]), col([s.sigma for s in supervisors]))
    rec = TeamingRecord() if record is not None else None
    every = max(1, int(round(0.25 / config.dt)))
    for step in range(int(round(config.duration / config.dt))):
        _drive(b, team_args, config)
        removed = _supervise(b, sup_args, config, rng)
        _end_trips(b, config, rng)
        if rec is not None:
            rec.removals += [(step * config.dt, o) for t, o in removed if t == record]
            if step % every == 0:
                rec.times.append(step * config.dt)
                rec.robots.append(b.robots[record].copy())
                rec.obstacles.append(b.obs[record].copy())
                rec.detected.append(b.detected[record].copy())
    unavoidable = b.counts.pop("unavoidable_false_positives")
    out = pd.DataFrame(b.counts)
    if details:
        out["unavoidable_false_positives"] = unavoidable
    out["score"] = (config.trip_reward * out["trips"] - config.collision_cost * out["collisions"]
                    - config.removal_cost * out["interventions"])
    return (out, rec) if record is not None else out


def _relative(robots, obstacles):
    """Robot states relative to every obstacle centre: (B, R, 3), (B, O, 2) -> (B, R, O, 3)."""
    p = robots[:, :, None, :2] - obstacles[:, None, :, :]
    theta = np.broadcast_to(robots[:, :, None, 2:3], p.shape[:-1] + (1,))
    return np.concatenate([p, theta], axis=-1)


def perfect_fit_trials(supervisors, versions, config=TeamingConfig(), seed=0):
    """The Property of Sec. 4.5: each supervisor, made noiseless, watches a team avoiding on that
    supervisor's own safe set ``{V_S >= mu}`` (a perfect fit), once per task version; returns the
    per-trial counts of :func:`simulate_teaming` with ``unavoidable_false_positives`` (false positives should
    be zero on exact values, except on obstacles that reappear with a robot already inside the supervisor's
    unsafe set; on the grid's values the interpolation error adds more, which ``config.filter_margin`` absorbs)."""
    pairs = [(s, v) for s in supervisors for v in versions]
    teams = [Team(s.value_fn, s.mu) for s, _ in pairs]
    noiseless = [NoisySupervisor(s.value_fn, s.mu, 0.0) for s, _ in pairs]
    return simulate_teaming(teams, noiseless, [v for _, v in pairs], config, seed, details=True)
