"""What keeps the benchmark's demonstrators safe: plain-NumPy RK4, a look-ahead safety filter, MPPI.

Everything here acts on the TRUE continuous dynamics, integrated with classical Runge-Kutta at the
demonstrator's own time step, as a user integrating their own controller would; nothing comes from
the grid model the inference uses.

* :func:`rk4` -- one RK4 step of ``f(x, u)`` for states (N, d), controls (N, m);
* :class:`Allowed` -- the set the demonstrator must stay in: outside every hidden region and, on the
  coordinates it names, inside the system's box;
* :func:`safety_filter` -- a backup-policy filter (a discrete-time version of the "backup" control
  barrier filters of Gurriet et al. 2018): a control is safe when one step under it followed by
  ``horizon`` steps of one of the backup policies stays in the allowed set (and, where the backup names
  one, ends in a set it keeps safe forever); the filter applies the
  nominal control if it is safe, else the safe control nearest to it among ``levels`` controls;
* :func:`mppi_plan` -- model-predictive path integral control (Williams et al. 2017) of corrections
  to a nominal feedback controller, with the hidden regions as a hard cost (the demonstrator passes
  its executed control through the filter as a guard).
"""

from dataclasses import dataclass

import numpy as np


def rk4(f, x, u, h):
    """One classical Runge-Kutta step of length ``h`` of x' = f(x, u), the control held."""
    k1 = f(x, u)
    k2 = f(x + 0.5 * h * k1, u)
    k3 = f(x + 0.5 * h * k2, u)
    k4 = f(x + h * k3, u)
    return x + (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)


@dataclass(frozen=True)
class Allowed:
    """Points allowed to a demonstrator: outside every region of ``hidden`` (each grown by ``margin``
    in its units) and, on coordinates ``box_dims``, inside [``low``, ``high``]; ``periodic``
    coordinates are wrapped into [low, high) before the regions are asked."""

    hidden: tuple
    low: np.ndarray
    high: np.ndarray
    periodic: tuple
    box_dims: tuple = ()
    margin: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "grown", tuple(r.inflated(self.margin) for r in self.hidden))

    def wrap(self, x):
        x = np.array(x, dtype=float, copy=True)
        for i in self.periodic:
            x[..., i] = self.low[i] + np.mod(x[..., i] - self.low[i], self.high[i] - self.low[i])
        return x

    def ok(self, x):
        """Booleans (N,) for points (N, d)."""
        x = self.wrap(x) if self.periodic else x
        good = np.ones(len(x), dtype=bool)
        for region in self.grown:
            good &= ~region.inside(x)
        for i in self.box_dims:
            good &= (x[:, i] >= self.low[i]) & (x[:, i] <= self.high[i])
        return good


@dataclass(frozen=True)
class Backup:
    """Backup policies (functions of states (N, d) returning controls (N, m)) followed for ``seconds``,
    and ``rest``: None, or a function ``rest(states, allowed)`` -> booleans saying the final states
    lie in a set the policy keeps allowed forever (a braked pendulum whose energy is low enough), so
    that the certificate does not expire at the end of the horizon."""

    policies: tuple
    seconds: float
    rest: object = None


def backup_safe(f, allowed, x, u, h, backup, low, high):
    """Booleans (N,): one step of ``h`` under ``u`` from ``x``, then some backup policy (its controls
    clipped to [``low``, ``high``]) for ``backup.seconds`` (RK4 steps of ``h``), stay allowed at every
    step."""
    N, B = len(x), len(backup.policies)
    first = rk4(f, x, u, h)
    now = allowed.ok(first)
    y = np.tile(first, (B, 1))
    good = np.tile(now, B)
    for _ in range(int(np.ceil(backup.seconds / h))):
        u_b = np.clip(np.concatenate([policy(y[i * N:(i + 1) * N]) for i, policy in enumerate(backup.policies)]),
                      low, high)
        y = rk4(f, y, u_b, h)
        good &= allowed.ok(y)
    if backup.rest is not None:
        good &= backup.rest(y, allowed)
    return now & good.reshape(B, N).any(axis=0)


def safety_filter(f, allowed, x, u_nominal, h, backup, low, high, levels=13):
    """Controls (N, m) to apply: the nominal one where it is safe (:func:`backup_safe`), else the safe
    control nearest to it among ``levels`` evenly spaced controls (one control coordinate); where
    none is safe, the first backup policy's control (the rollout then checks that the truth held)."""
    u = np.clip(np.asarray(u_nominal, dtype=float), low, high)
    ok = backup_safe(f, allowed, x, u, h, backup, low, high)
    if ok.all():
        return u
    bad = np.flatnonzero(~ok)
    u[bad], found = _nearest_safe(f, allowed, x[bad], u[bad], h, backup, np.linspace(low, high, levels), low, high)
    u[bad[~found]] = np.clip(backup.policies[0](x[bad[~found]]), low, high)
    return u


def _nearest_safe(f, allowed, x, u, h, backup, grid, low, high):
    """The safe control of ``grid`` (K, m) nearest to ``u`` (N, m) from each state, and whether one was."""
    xs = np.repeat(x, len(grid), axis=0)
    us = np.tile(grid, (len(x), 1))
    safe = backup_safe(f, allowed, xs, us, h, backup, low, high).reshape(len(x), len(grid))
    dist = np.linalg.norm(grid[None] - u[:, None], axis=2)
    dist[~safe] = np.inf
    best = np.argmin(dist, axis=1)
    found = np.isfinite(dist[np.arange(len(x)), best])
    return np.where(found[:, None], grid[best], u), found


@dataclass(frozen=True)
class MPPISettings:
    """MPPI: ``samples`` correction sequences of ``steps`` held corrections of ``step`` seconds each,
    exploration ``sigma`` (a share of the control range), hard cost ``violation`` per step in a
    hidden region, and the quantile ``elite`` of the sampled costs that sets the temperature."""

    samples: int = 128
    steps: int = 15
    step: float = 0.1
    sigma: float = 0.3
    violation: float = 1e4
    elite: float = 0.2


def mppi_plan(f, allowed, cost, terminal, policy, x, plan, low, high, rng, settings, substeps):
    """One MPPI update of the plans (N, steps, m) from states (N, d). A plan is a sequence of
    corrections added to the feedback ``policy`` (an MPPI around a nominal controller): sampled
    perturbations of the corrections, rollouts (``substeps`` RK4 steps per held correction; controls
    clipped to [low, high]), costs ``cost(x, u) * step`` per step plus ``violation`` where not
    allowed and ``terminal(x)`` at the end, and the exponentially weighted mean of the sampled plans
    (the temperature: the gap between the best cost and the ``elite`` quantile of each state's costs,
    so that the best samples carry the mean, however costly the rest). Returns the new plans."""
    N, H, m = plan.shape
    K, span = settings.samples, np.asarray(high) - np.asarray(low)
    U = plan[:, None] + rng.normal(0.0, settings.sigma, size=(N, K, H, m)) * span
    y = np.repeat(x, K, axis=0)
    total = np.zeros(N * K)
    h = settings.step / substeps
    for t in range(H):
        correction = U[:, :, t].reshape(N * K, m)
        for _ in range(substeps):
            u = np.clip(policy(y) + correction, low, high)
            total += cost(y, u) * h
            y = rk4(f, y, u, h)
        total += settings.violation * ~allowed.ok(y)
    total = (total + terminal(y)).reshape(N, K)
    best = total.min(axis=1, keepdims=True)
    spread = np.quantile(total, settings.elite, axis=1, keepdims=True) - best
    w = np.exp(-(total - best) / (spread + 1e-9))
    w /= w.sum(axis=1, keepdims=True)
    return np.einsum("nk,nkhm->nhm", w, U)
