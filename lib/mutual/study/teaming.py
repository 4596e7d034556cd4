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

from ..supervision import NoisySupervisor, ValueFunction
from .design import OBSTACLE_RADIUS
from .teaming_batch import _candidates, _drive, _end_trips, _start_batch, _supervise
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
    layouts = {v: task_layout(v, config) for v in dict.fromkeys(versions)}   # a layout depends on its version
    b = _start_batch(versions, layouts, config, rng, details)
    team_stack = _Stack(*_unique([t.value for t in teams]), "team")
    team_stack.w_max = np.array([t.value.w_max for t in teams])
    sup_stack = _Stack(*_unique([s.value_fn for s in supervisors]), "supervisor")
    alpha = np.array([t.alpha for t in teams], dtype=float)
    team_args = (team_stack, alpha, team_stack.reach(alpha + config.filter_margin))
    sup_args = (sup_stack, np.array([s.mu for s in supervisors], dtype=float),
                np.array([s.sigma for s in supervisors], dtype=float))
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
                rec.robots.append(np.stack([b.x[record], b.y[record], b.theta[record]], axis=1))
                rec.obstacles.append(np.stack([b.ox[record], b.oy[record]], axis=1))
                rec.detected.append(b.detected[record].copy())
    unavoidable = b.counts.pop("unavoidable_false_positives")
    out = pd.DataFrame(b.counts)
    if details:
        out["unavoidable_false_positives"] = unavoidable
    out["score"] = (config.trip_reward * out["trips"] - config.collision_cost * out["collisions"]
                    - config.removal_cost * out["interventions"])
    return (out, rec) if record is not None else out


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
