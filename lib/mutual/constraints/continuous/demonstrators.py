"""Demonstrators that act on the TRUE continuous system and respect a hidden constraint.

Demonstrations for testing the method must never come from the grid MDP used for inference. Two
demonstrators, both rolled out by integrating the continuous dynamics (RK4), both respecting the
hidden regions exactly (every executed step is checked on the continuous trajectory, at each RK4
sub-step; an action that would enter a hidden region is never taken):

* :func:`soft_demonstrator` -- a maximum-causal-entropy (Boltzmann) demonstrator (eq. 2.19) solved
  on a much finer grid with its own control set (barycentric discretization, every cell touching a
  hidden region forbidden outright, psi = 0), acting by state feedback from the cell it is in;
* :func:`mppi_rollouts` -- sampled trajectory optimisation (MPPI, Williams et al. 2017) on the
  continuous system with continuous controls; its temperature is the reward's temperature
  (path-integral control is the trajectory-level maximum-entropy model).

Suboptimal demonstrators: a higher temperature, or ``noise`` -- the probability of a uniformly
random safe action (soft) or the standard deviation of noise on the applied control, as a share of
the control range (MPPI). Both return a :class:`~.recordings.Recording` sampled every
``dt / record_every`` seconds, with the controls applied.
"""

from dataclasses import dataclass, replace

import numpy as np

from ... import budget
from ..mdp import expected_next, masked_logsumexp
from .discretization import discretize
from .grid import Grid
from .recordings import Recording
from .regions import Bound, cells_in
from .systems import integrate

VIOLATION_COST = 1e3   # MPPI: cost of a planned step inside a hidden region (executed steps never enter one)


def _violates(problem, hidden, x, u):
    """Whether the step from x (N, d) under u (N, m) enters a hidden region at any RK4 sub-step;
    and the successor (N, d)."""
    bad = np.zeros(len(x), dtype=bool)
    for _ in range(problem.substeps):
        x = problem.grid.wrap(integrate(problem.system, x, u, problem.dt / problem.substeps, 1))
        for region in hidden:
            bad |= region.inside(x)
    return bad, x


@dataclass(eq=False)
class SoftDemonstrator:
    """The fine-grid Boltzmann demonstrator: its ``problem`` (fine grid, own controls), ``mdp``,
    allowed-action ``mask`` (no chance of entering a hidden region), soft values ``V`` (T+1, X)."""

    problem: object
    mdp: object
    mask: np.ndarray
    V: np.ndarray
    hidden: tuple

    def q_values(self, t, cells):
        """Q_t(x, a) (N, A) of the cells (eq. 2.20), -inf where forbidden."""
        A = self.mdp.n_actions
        rows = (cells[:, None] * A + np.arange(A)).ravel()
        S, V = self.mdp.transitions[rows], self.V[t + 1]
        dead = np.isneginf(V)
        EV = np.asarray(S @ np.where(dead, 0.0, V)).reshape(-1, A)
        EV[np.asarray(S @ dead.astype(float)).reshape(-1, A) > 0] = -np.inf
        Q = self.mdp.reward[cells] + EV
        Q[~self.mask[cells]] = -np.inf
        return Q


def touching(region, grid):
    """Cells that touch ``region`` (their centre within half a cell of it): ``region`` grown by half a
    cell -- half the cell width for a bound, half the cell diagonal in the plane for an obstacle."""
    dims = [region.dim] if isinstance(region, Bound) else list(region.dims)
    half = 0.5 * np.sqrt(sum(np.max(grid.widths_1d(i)) ** 2 for i in dims))
    return cells_in(region.inflated(half), grid)


def soft_demonstrator(problem, hidden, cells, controls=None, temperature=None, scheduler="auto"):
    """A :class:`SoftDemonstrator` for ``problem``'s task under the ``hidden`` regions, on a uniform
    grid of ``cells`` per coordinate over the same box, with ``controls`` (default: the problem's)
    and ``temperature`` (default: the problem's). Its grid forbids, with probability 0, every cell that
    touches a hidden region (:func:`touching`): it keeps the margin a cell's extent needs."""
    g = problem.grid
    n_controls = len(problem.controls if controls is None else controls)
    budget.check(budget.soft_demonstrator(cells, n_controls, problem.horizon))
    fine_grid = Grid.uniform(g.low, g.high, cells, g.periodic, g.names, g.units)
    reward = problem.reward if temperature is None else replace(problem.reward, temperature=float(temperature))
    fine = problem.replace(grid=fine_grid, controls=problem.controls if controls is None else controls,
                           scheme="barycentric", reward=reward)
    S = discretize(fine, scheduler=scheduler)
    mdp = fine.mdp(S)
    inside = np.zeros(fine_grid.n_cells, dtype=bool)
    for region in hidden:
        inside |= touching(region, fine_grid)
    mask = (np.asarray(S @ inside.astype(float)).ravel() <= 0).reshape(mdp.n_states, mdp.n_actions)
    V = np.empty((mdp.horizon + 1, mdp.n_states))
    V[-1] = mdp.terminal_reward
    for t in range(mdp.horizon - 1, -1, -1):
        V[t] = masked_logsumexp(mdp.reward + expected_next(mdp, V[t + 1]), ~mask)
    return SoftDemonstrator(fine, mdp, mask, V, tuple(hidden))


def _record(problem, hidden, x, u, record_every):
    """Integrate one control step in ``record_every`` pieces: the recorded states (k, N, d), the
    successor, and whether a hidden region was entered."""
    piece = problem.replace(dt=problem.dt / record_every, substeps=max(1, problem.substeps // record_every))
    states, bad = [], np.zeros(len(x), dtype=bool)
    for _ in range(record_every):
        b, x = _violates(piece, hidden, x, u)
        bad |= b
        states.append(x)
    return states, x, bad


def rollout(demonstrator, starts, seed=0, noise=0.0, record_every=1):
    """Continuous demonstrations of a :class:`SoftDemonstrator` from ``starts`` (N, d): at each step
    the Boltzmann policy of the cell the state is in, over the actions that keep the continuous
    step out of the hidden regions (uniformly over those where the fine grid leaves none)."""
    p, dem = demonstrator.problem, demonstrator
    rng = np.random.default_rng(seed)
    x = p.grid.wrap(np.atleast_2d(np.asarray(starts, dtype=float)))
    N, A = len(x), p.n_actions
    budget.check(budget.rollouts(N, p.horizon, p.grid.ndim, A, record_every=record_every))
    if np.isneginf(dem.V[0][p.grid.cell_of(x)]).any():
        raise ValueError(f"demonstrator: on its {' x '.join(map(str, p.grid.shape))} grid no trajectory from some start "
                         "avoids the hidden regions (V = -inf there); use a finer demonstrator grid")
    states, controls = [[row] for row in x], [[] for _ in range(N)]
    for t in range(p.horizon):
        safe = ~_violates(p, dem.hidden, np.repeat(x, A, axis=0), np.tile(p.controls, (N, 1)))[0].reshape(N, A)
        if not safe.any(axis=1).all():
            raise ValueError(f"demonstrator: from some state at step {t} every control enters a hidden region; "
                             "start farther from it or use a finer demonstrator grid")
        Q = np.where(safe, dem.q_values(t, p.grid.cell_of(x)), -np.inf)
        lost = ~np.isfinite(Q).any(axis=1)             # the fine grid leaves no action: uniform over safe ones
        Q[lost] = np.where(safe[lost], 0.0, -np.inf)
        prob = np.exp(Q - Q.max(axis=1, keepdims=True))
        prob /= prob.sum(axis=1, keepdims=True)
        explore = rng.random(N) < noise
        prob[explore] = safe[explore] / safe[explore].sum(axis=1, keepdims=True)
        a = (prob.cumsum(axis=1) < rng.random(N)[:, None]).sum(axis=1).clip(0, A - 1)
        x = _step_and_record(p, dem.hidden, x, p.controls[a], record_every, states, controls)
    return _recording(p, states, controls, record_every, "soft demonstrator")


def _step_and_record(problem, hidden, x, u, record_every, states, controls):
    pieces, x, bad = _record(problem, hidden, x, u, record_every)
    if bad.any():      # pragma: no cover - the actions were checked on the same integration
        raise RuntimeError("demonstrator: a checked step entered a hidden region")
    for n in range(len(x)):
        states[n].extend(piece[n] for piece in pieces)
        controls[n].extend([u[n]] * record_every)
    return x


def _recording(problem, states, controls, record_every, source):
    L = len(controls[0])
    times = np.arange(L + 1) * problem.dt / record_every
    ids = tuple(f"demo-{n:03d}" for n in range(len(states)))
    ctrl = tuple(np.vstack([np.asarray(c), np.full((1, problem.controls.shape[1]), np.nan)]) for c in controls)
    return Recording(ids, tuple(times for _ in states), tuple(np.asarray(s) for s in states), ctrl, None, source)


def mppi_rollouts(problem, hidden, starts, seed=0, samples=256, plan_steps=20, sigma=0.5, noise=0.0,
                  record_every=1, margin=0.0):
    """Continuous demonstrations by MPPI from ``starts`` (N, d) (module docstring): ``samples``
    control sequences of ``plan_steps`` steps per decision, exploration ``sigma`` and execution
    ``noise`` as shares of the control range; a planned step inside a hidden region grown by
    ``margin`` (the demonstrator's caution, in the region's units) costs ``VIOLATION_COST``, and the
    executed control is replaced by the nearest safe one of the set if it would enter a hidden region."""
    rng = np.random.default_rng(seed)
    lo, hi = problem.controls.min(axis=0), problem.controls.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    x = problem.grid.wrap(np.atleast_2d(np.asarray(starts, dtype=float)))
    N, m = x.shape[0], lo.size
    budget.check(budget.rollouts(N, problem.horizon, problem.grid.ndim, record_every=record_every, plans=samples,
                                 plan_steps=plan_steps))
    U = np.zeros((N, plan_steps, m))
    planned = [region.inflated(margin) for region in hidden]
    states, controls = [[row] for row in x], [[] for _ in range(N)]
    for _ in range(problem.horizon):
        U = _mppi_update(problem, planned, x, U, rng, samples, sigma * span, lo, hi)
        u = np.clip(U[:, 0] + noise * span * rng.standard_normal((N, m)), lo, hi)
        u = _safe_control(problem, hidden, x, u)
        x = _step_and_record(problem, hidden, x, u, record_every, states, controls)
        U = np.concatenate([U[:, 1:], U[:, -1:]], axis=1)
    return _recording(problem, states, controls, record_every, "MPPI")


def _mppi_update(problem, hidden, x, U, rng, K, scale, lo, hi):
    """One MPPI update of the nominal sequences U (N, H, m) from states x (N, d)."""
    N, H, m = U.shape
    trial = np.clip(U[:, None] + scale * rng.standard_normal((N, K, H, m)), lo, hi)
    trial[:, 0] = U                                                  # keep the nominal among the samples
    z = np.repeat(x, K, axis=0)
    cost = np.zeros(N * K)
    g = problem.grid
    for h in range(H):
        u = trial[:, :, h].reshape(N * K, m)
        cost -= problem.reward.rate(g, z, u) * problem.dt
        bad, z = _violates(problem, hidden, z, u)
        cost[bad] += VIOLATION_COST
    cost = (cost - problem.reward.terminal(g, z)).reshape(N, K)
    w = np.exp(-(cost - cost.min(axis=1, keepdims=True)) / problem.reward.temperature)
    w /= w.sum(axis=1, keepdims=True)
    return np.einsum("nk,nkhm->nhm", w, trial)


def _safe_control(problem, hidden, x, u):
    """``u`` where its step stays out of the hidden regions, else the nearest safe control of the set."""
    bad, _ = _violates(problem, hidden, x, u)
    if not bad.any():
        return u
    A = problem.n_actions
    options = problem.controls
    unsafe = _violates(problem, hidden, np.repeat(x[bad], A, axis=0), np.tile(options, (int(bad.sum()), 1)))[0]
    unsafe = unsafe.reshape(-1, A)
    dist = ((u[bad][:, None, :] - options[None]) ** 2).sum(axis=2)
    dist[unsafe] = np.inf
    if not np.isfinite(dist).any(axis=1).all():
        raise ValueError("demonstrator: from some state every control enters a hidden region; start farther from it")
    u = u.copy()
    u[bad] = options[np.argmin(dist, axis=1)]
    return u


def starts_around(start, spread, n, seed=0):
    """``n`` start states uniformly within ``start`` +- ``spread`` (per coordinate)."""
    rng = np.random.default_rng(seed)
    start, spread = np.asarray(start, dtype=float), np.asarray(spread, dtype=float)
    budget.check(budget.array((n, start.size), what="start states", knob="ask for fewer starts (n)"))
    return start + spread * rng.uniform(-1.0, 1.0, size=(int(n), start.size))

