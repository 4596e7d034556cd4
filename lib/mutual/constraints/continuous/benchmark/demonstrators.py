"""The benchmark's demonstrators: hand-written controllers behind a safety filter, and MPPI.

Every demonstrator integrates the TRUE dynamics (the library's named system, its default
parameters) with plain-NumPy RK4 (:func:`.safety.rk4`) at its system's own time step
(:attr:`.setups.Setup.demo_dt`), decides a control every step, passes it through the look-ahead
safety filter (:func:`.safety.safety_filter`) that keeps it out of the hidden regions, and records
the true state and the applied control at every step. Kinds (``KINDS``):

* ``"filter"`` -- the nominal controller (:mod:`.controllers`);
* ``"noisy"`` -- the controller sees the state with Gaussian sensor noise (2 % of the box per
  coordinate) and its control gets actuator noise (10 % of the control range), before the filter;
* ``"random20"`` -- every decision period (the system file's dt) the control is, with chance 0.2,
  uniformly random in the control range instead of the controller's;
* ``"lagged"`` -- wrong gains (half the nominal ones) and a sensing delay of 0.1 s;
* ``"mppi"`` -- MPPI of corrections to the nominal controller on the system file's task (running
  and terminal cost over its plan) with the hidden regions as a hard cost
  (:func:`.safety.mppi_plan`), replanning every decision period, behind the same filter as a guard.

Start states: ``"narrow"`` or ``"wide"`` boxes around the task's start (``STARTS``). The rollout
checks every recorded state against the hidden regions and raises if one is violated.
"""

import numpy as np

from ..recordings import Recording
from .controllers import CONTROLLERS
from .safety import Allowed, MPPISettings, mppi_plan, rk4, safety_filter

#: the filter keeps this far (in each region's units) from the hidden regions' boundary
MARGIN = 0.01
KINDS = ("filter", "noisy", "random20", "lagged", "mppi")

#: system -> start distribution -> (centre, half-width) per coordinate
STARTS = {
    "pendulum": {"narrow": ([0.0, 0.0], [0.1, 0.1]), "wide": ([0.0, 0.0], [1.0, 1.0])},
    "double_integrator": {"narrow": ([0.0, 0.0], [0.1, 0.0]), "wide": ([0.0, 0.0], [0.5, 0.3])},
    "cartpole": {"narrow": ([-1.0, 0.0, 0.0, 0.0], [0.05, 0.02, 0.02, 0.02]),
                 "wide": ([-1.0, 0.0, 0.0, 0.0], [0.2, 0.1, 0.05, 0.1])},
    "car": {"narrow": ([-2.5, 0.0, 0.0], [0.0, 0.2, 0.1]), "wide": ([-2.5, 0.0, 0.0], [0.3, 0.6, 0.3])},
}


class _Context:
    """A system file's problem seen by a demonstrator: dynamics, box, controls, task, filter."""

    def __init__(self, setup, hidden):
        spec = setup.system_file()
        self.setup, self.problem, self.hidden = setup, spec.problem, list(hidden)
        p, g = self.problem, self.problem.grid
        self.f = p.system.f
        self.h = setup.demo_dt
        self.steps = int(round(p.horizon * p.dt / self.h))
        self.decide = max(1, int(round(p.dt / self.h)))          # own steps per decision period
        self.low, self.high = p.controls.min(axis=0), p.controls.max(axis=0)
        self.goal = p.reward.goal
        periodic = tuple(int(i) for i in np.flatnonzero(g.periodic))
        box = () if setup.name == "car" else tuple(i for i in range(g.ndim) if i not in periodic)
        self.allowed = Allowed(tuple(self.hidden), g.low, g.high, periodic, box, margin=MARGIN)
        self.truth = Allowed(tuple(self.hidden), g.low, g.high, periodic)
        self.controller, backup = CONTROLLERS[setup.name]
        self.backup = backup(self.allowed)

    def filtered(self, x, u):
        return safety_filter(self.f, self.allowed, x, u, self.h, self.backup, self.low, self.high)

    def cost(self, x, u):
        return -self.problem.reward.rate(self.problem.grid, self.allowed.wrap(x), u)

    def nominal(self, x):
        return self.controller(x, self.goal)

    def terminal(self, x):
        return -self.problem.reward.terminal(self.problem.grid, self.allowed.wrap(x))


def starts(system, which, n, seed):
    """``n`` start states uniformly in the ``which`` ("narrow", "wide") box of ``system``."""
    centre, half = (np.asarray(v, dtype=float) for v in STARTS[system][which])
    return centre + half * np.random.default_rng(seed).uniform(-1.0, 1.0, size=(n, centre.size))


def _nominal(ctx, kind, history, k, rng, plan):
    """The demonstrator's wanted control (N, m) at own step k from the state ``history``."""
    x = history[k]
    if kind == "lagged":
        x = history[max(0, k - int(round(0.1 / ctx.h)))]
    if kind == "noisy":
        x = x + rng.normal(0.0, 0.02, size=x.shape) * (ctx.problem.grid.high - ctx.problem.grid.low)
    u = ctx.controller(x, ctx.goal, gain=0.5 if kind == "lagged" else 1.0)
    if kind == "noisy":
        u = u + rng.normal(0.0, 0.1, size=u.shape) * (ctx.high - ctx.low)
    if kind == "mppi":
        u = u + plan[:, 0]
    return u


def rollout(setup, kind, hidden, x0, seed):
    """States (N, L+1, d) and applied controls (N, L, m) of demonstrator ``kind`` of ``setup`` from
    the starts ``x0`` (N, d) under the ``hidden`` regions, at the setup's own time step."""
    if kind not in KINDS:
        raise ValueError(f"demonstrator: unknown kind {kind!r}; known: {', '.join(KINDS)}")
    ctx, rng = _Context(setup, hidden), np.random.default_rng(seed)
    N, m = len(x0), ctx.problem.system.n_controls
    history = np.empty((ctx.steps + 1, N, x0.shape[1]))
    history[0] = ctx.allowed.wrap(x0)
    applied = np.empty((ctx.steps, N, m))
    settings = MPPISettings(step=ctx.decide * ctx.h)
    plan = np.zeros((N, settings.steps, m))
    held = None
    for k in range(ctx.steps):
        x = history[k]
        if k % ctx.decide == 0:
            if kind == "mppi":
                plan = mppi_plan(ctx.f, ctx.allowed, ctx.cost, ctx.terminal, ctx.nominal, x, plan, ctx.low, ctx.high, rng, settings, ctx.decide)
            held = rng.random(N) < 0.2 if kind == "random20" else np.zeros(N, dtype=bool)
            random_u = rng.uniform(ctx.low, ctx.high, size=(N, m))
        u = np.where(held[:, None], random_u, _nominal(ctx, kind, history, k, rng, plan))
        applied[k] = u = ctx.filtered(x, u)
        history[k + 1] = ctx.allowed.wrap(rk4(ctx.f, x, u, ctx.h))
        if kind == "mppi" and (k + 1) % ctx.decide == 0:
            plan = np.concatenate([plan[:, 1:], plan[:, -1:]], axis=1)
    states = history.transpose(1, 0, 2)
    bad = ~ctx.truth.ok(states.reshape(-1, states.shape[2]))
    if bad.any():
        d, k = np.unravel_index(int(np.flatnonzero(bad)[0]), states.shape[:2])
        raise RuntimeError(f"demonstrator {kind!r} of {setup.name}: demonstration {d} entered a hidden region at "
                           f"step {k} (state {states[d, k]})")
    return states, applied.transpose(1, 0, 2)


def recording(setup, states, controls, record_controls=True, source="benchmark"):
    """The :class:`~mutual.constraints.continuous.Recording` of a rollout: demonstrations ``d00``,
    ``d01``, ... sampled at the setup's own time step, the controls recorded (empty on the last row)
    or not."""
    n, L1, _ = states.shape
    times = np.arange(L1) * setup.demo_dt
    ctrl = None
    if record_controls:
        ctrl = tuple(np.vstack([c, np.full((1, c.shape[1]), np.nan)]) for c in controls)
    return Recording(tuple(f"d{i:02d}" for i in range(n)), tuple(times.copy() for _ in range(n)),
                     tuple(states), ctrl, None, source)
