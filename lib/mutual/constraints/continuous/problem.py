"""A continuous constraint-inference problem: the system, the grid, the controls, the time step and
the demonstrator's task, turned into the tabular MDP of Section 2.2.1 on the grid.

The task is a quadratic reward in continuous time: per second, r(x, u) = -(sum_i q_i e_i^2 +
sum_j c_j u_j^2) with e = x - goal (wrapped into (-period/2, period/2] on periodic coordinates),
and at the end w(x_T) = -sum_i Q_i e_i^2. The tabular MDP collects r(centre of x, u_a) dt per step
and w(centre of x_T), all divided by the ``temperature`` (eq. 2.19: the demonstrator is
Boltzmann-rational in these units; a higher temperature is a noisier demonstrator).
"""

from dataclasses import dataclass, replace

import numpy as np

from ..mdp import MDP
from .grid import Grid
from .systems import System, integrate

SCHEMES = ("sample", "barycentric")


@dataclass(frozen=True, eq=False)
class QuadraticReward:
    """The demonstrator's task (module docstring): ``goal`` and weights per coordinate and control."""

    goal: np.ndarray
    state_weights: np.ndarray
    control_weights: np.ndarray
    terminal_weights: np.ndarray
    temperature: float = 1.0

    def __post_init__(self):
        for name in ("goal", "state_weights", "control_weights", "terminal_weights"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.ndim != 1 or not np.all(np.isfinite(value)):
                raise ValueError(f"reward: {name} must be a list of finite numbers")
            if name != "goal" and np.any(value < 0):
                raise ValueError(f"reward: {name} must be >= 0 (a cost on squared errors)")
            object.__setattr__(self, name, value)
        if not np.isfinite(self.temperature) or self.temperature <= 0:
            raise ValueError(f"reward: temperature must be a positive number, got {self.temperature!r}")

    def errors(self, grid, x):
        """x - goal (N, d), periodic coordinates wrapped into (-period/2, period/2]."""
        e = np.asarray(x, dtype=float) - self.goal
        for i in np.flatnonzero(grid.periodic):
            period = grid.high[i] - grid.low[i]
            e[:, i] = -(np.mod(-e[:, i] + period / 2, period) - period / 2)
        return e

    def rate(self, grid, x, u):
        """r(x, u) per second (N,) for states (N, d) and controls (N, m)."""
        return -((self.errors(grid, x) ** 2) @ self.state_weights + (np.asarray(u) ** 2) @ self.control_weights)

    def terminal(self, grid, x):
        """w(x) (N,)."""
        return -((self.errors(grid, x) ** 2) @ self.terminal_weights)


@dataclass(frozen=True, eq=False)
class Problem:
    """Everything that defines the tabular MDP of a continuous system: ``system``, ``grid``,
    ``controls`` (A, m) the discrete control set, ``dt`` seconds per step, ``horizon`` T steps,
    the ``reward``, the discretization ``scheme`` ("sample": ``samples`` Monte Carlo states per
    cell, seeded by ``seed``; "barycentric": Kuhn-triangulation interpolation) and RK4 ``substeps``."""

    system: System
    grid: Grid
    controls: np.ndarray
    dt: float
    horizon: int
    reward: QuadraticReward
    scheme: str = "sample"
    samples: int = 16
    substeps: int = 4
    seed: int = 0

    def __post_init__(self):
        controls = np.asarray(self.controls, dtype=float)
        if controls.ndim == 1:
            controls = controls[:, None]
        if controls.ndim != 2 or controls.shape[1] != self.system.n_controls or controls.shape[0] < 1:
            raise ValueError(f"controls: need a list of controls with {self.system.n_controls} value(s) each")
        if not np.all(np.isfinite(controls)) or len(np.unique(controls, axis=0)) != len(controls):
            raise ValueError("controls: must be finite and distinct")
        object.__setattr__(self, "controls", controls)
        if tuple(self.grid.names) != tuple(self.system.state_names):
            raise ValueError(f"grid: coordinates {list(self.grid.names)} differ from the system's "
                             f"{list(self.system.state_names)}")
        checks = (("dt", self.dt, lambda v: v > 0 and np.isfinite(v), "a positive number of seconds"),
                  ("horizon", self.horizon, lambda v: isinstance(v, (int, np.integer)) and v >= 1, "an integer >= 1"),
                  ("scheme", self.scheme, lambda v: v in SCHEMES, f"one of {list(SCHEMES)}"),
                  ("samples", self.samples, lambda v: isinstance(v, (int, np.integer)) and v >= 1, "an integer >= 1"),
                  ("substeps", self.substeps, lambda v: isinstance(v, (int, np.integer)) and v >= 1, "an integer >= 1"),
                  ("seed", self.seed, lambda v: isinstance(v, (int, np.integer)) and v >= 0, "an integer >= 0"))
        for name, value, ok, what in checks:
            if isinstance(value, bool) or not ok(value):
                raise ValueError(f"{name}: must be {what}, got {value!r}")
        n = self.grid.ndim
        for name in ("goal", "state_weights", "terminal_weights"):
            if getattr(self.reward, name).shape != (n,):
                raise ValueError(f"reward: {name} needs {n} values, one per state coordinate")
        if self.reward.control_weights.shape != (self.system.n_controls,):
            raise ValueError(f"reward: control_weights needs {self.system.n_controls} value(s), one per control")

    def __repr__(self):
        return (f"Problem({self.system.spec!r} on {self.grid!r}, {self.n_actions} controls, dt = {self.dt:g} s, "
                f"T = {self.horizon}, scheme {self.scheme!r})")

    @property
    def n_actions(self):
        return self.controls.shape[0]

    def replace(self, **changes):
        """A copy with some fields changed (``dataclasses.replace``)."""
        return replace(self, **changes)

    def step(self, x, u):
        """Continuous states (N, d) after one step ``dt`` under controls ``u`` (N, m), wrapped."""
        return self.grid.wrap(integrate(self.system, x, u, self.dt, self.substeps))

    def rewards(self):
        """The MDP's running reward r(x, a) dt / temperature (X, A) and terminal reward (X,) at cell centres."""
        centres = self.grid.centers()
        X, A = len(centres), self.n_actions
        x = np.repeat(centres, A, axis=0)
        u = np.tile(self.controls, (X, 1))
        running = self.reward.rate(self.grid, x, u).reshape(X, A) * self.dt / self.reward.temperature
        return running, self.reward.terminal(self.grid, centres) / self.reward.temperature

    def mdp(self, transitions):
        """The tabular MDP (Section 2.2.1) with the discretized ``transitions`` S (X*A, X)."""
        running, terminal = self.rewards()
        return MDP(transitions, running, int(self.horizon), terminal_reward=terminal)
