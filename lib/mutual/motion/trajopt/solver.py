"""Iterative LQR (Todorov & Li 2005) with Tassa-style regularisation, for eq. (6.4) in discrete time.

The problem, with ``x_0`` given and the horizon ``N`` set by the control sequence::

    min_u  sum_{k<N} running_cost(x_k, u_k, params) + terminal_cost(x_N, params)
    s.t.   x_{k+1} = dynamics(x_k, u_k, params)

The three callables are written with ``jax.numpy``; their derivatives come from JAX autodiff
(exact, no finite differences). The whole solve is one jit-compiled ``jax.lax.while_loop`` per
set of callables (:mod:`.compiled`; ``params`` is traced, so a family of
problems shares one compilation), and :func:`ilqr_batch` solves many problems at once under
``jax.vmap``. All arithmetic is float64.

Each iteration linearises the dynamics and takes a second-order model of the cost along the
current trajectory (Gauss-Newton: the dynamics' curvature is dropped; ``second_order=True`` keeps
it, which is full DDP; the default ``"auto"`` switches from the first to the second near the
minimum), runs the Riccati-like backward pass for an affine policy
``du = k + K dx`` and rolls the policy out with a backtracking line search. Objectives need not
be convex, e.g. the legible ``(1 + alpha) J1 - J0`` of eq. (6.15): the control block ``Q_uu`` is
regularised to ``Q_uu + mu c I`` whenever it is not positive definite.

Convergence and divergence tests are scale-free (see :mod:`.iteration`): they do
not change when the objective is multiplied by a constant (1e-6 or 1e6) and do not mistake a far
start for a solution. A run that diverges, an objective unbounded below, or a stationary point
that is not a minimum raises :class:`ILQRError` with the reason.
"""

from dataclasses import dataclass

import jax
import numpy as np

from .checks import check_batch, check_problem, x64
from .compiled import kernels
from .iteration import CONVERGED, DIVERGED, INDEFINITE, NO_DECREASE, NONFINITE_START, SUMMARY
from .settings import BATCH_DEFAULT, DEFAULT, ILQRSettings


SADDLE_ESCAPES = 3  # restarts from a saddle along its most negative curvature before reporting it


class ILQRError(RuntimeError):
    """iLQR could not find a local minimum: the objective is unbounded below or the run diverged."""


@dataclass(frozen=True, repr=False)
class ILQRResult:
    """A converged iLQR solution.

    ``xs`` (N+1, n) states, ``us`` (N, m) controls, ``K`` (N, m, n) the feedback gains of the last
    backward pass, ``cost`` the objective, ``iterations`` the number of accepted steps, ``costs``
    the objective after each of them (starting with the initial guess), ``reg`` the
    regularisation ``mu`` (relative to the control curvature) of the last backward pass,
    ``decrease`` the last predicted decrease relative to the objective's magnitude (the
    scale-free gradient test), ``magnitude`` that magnitude (sum of absolute stage costs).
    """

    xs: np.ndarray
    us: np.ndarray
    K: np.ndarray
    cost: float
    iterations: int
    costs: np.ndarray
    reg: float
    decrease: float = float("nan")
    magnitude: float = float("nan")
    passes: int = 0

    def __repr__(self):
        N, m = self.us.shape
        return (f"ILQRResult(cost={self.cost:.6g}, iterations={self.iterations}, N={N}, n={self.xs.shape[1]}, "
                f"m={m}, relative decrease={self.decrease:.1e})")


def _host(arrays):
    """The solve's outputs as NumPy arrays (``np.asarray`` each: a third of ``jax.device_get``'s cost here)."""
    return tuple(np.asarray(a) for a in arrays)


def _settings(settings, changes, default):
    """``settings`` (None: ``default``) with the keyword ``changes`` applied."""
    if settings is None:
        settings = default
    elif not isinstance(settings, ILQRSettings):
        raise ValueError(f"settings must be an ILQRSettings (mutual.motion.trajopt.ILQRSettings), got "
                         f"{type(settings).__name__}")
    return settings.replace(**changes) if changes else settings


class _SaddleError(ILQRError):
    """A stationary point that is not a minimum (iLQR may escape it along negative curvature)."""


def _saddle_error(message):
    return _SaddleError(message)


def _escape_saddle(dynamics, running_cost, terminal_cost, x0, us, params):
    """Controls that lower the cost from the saddle ``us`` along the direction of most negative
    curvature of the exact Hessian (both signs, backtracking from a unit step), or None."""
    compiled = kernels(dynamics, running_cost, terminal_cost)
    H = np.asarray(compiled.hessian(us, x0, params))
    values, vectors = np.linalg.eigh(0.5 * (H + H.T))
    if values[0] >= 0:
        return None
    base = float(compiled.value_and_grad(us, x0, params)[0])
    direction = vectors[:, 0].reshape(us.shape)
    size = max(1.0, float(np.abs(us).max()))
    for step in size * 0.5 ** np.arange(20):
        for sign in (1.0, -1.0):
            trial = us + sign * step * direction
            if float(compiled.value_and_grad(trial, x0, params)[0]) < base:
                return trial
    return None


def _outcome(xs, us, K, costs, summary, settings):
    """An :class:`ILQRResult`, or the :class:`ILQRError` that says why there is none (not raised)."""
    end = dict(zip(SUMMARY, np.asarray(summary).tolist()))
    status, steps = int(end["status"]), int(end["steps"])
    costs = np.asarray(costs)[:steps + 1]
    cost, mag = float(costs[-1]), end["magnitude"]
    relative = end["decrease"] / mag if mag > 0 else end["decrease"]
    if status == CONVERGED and end["minimum"]:
        return ILQRResult(xs=np.asarray(xs), us=np.asarray(us), K=np.asarray(K), cost=cost, iterations=steps,
                          costs=costs, reg=end["mu"], decrease=float(relative), magnitude=float(mag),
                          passes=int(end["passes"]))
    if status == CONVERGED:
        return _saddle_error(f"iLQR stopped at a stationary point (cost {cost:.6g}) that is not a local minimum: "
                         "the exact Hessian of the cost in the controls is not positive definite; the objective "
                         "may be unbounded below, or a symmetric start sits on a saddle (start from a perturbed "
                         "guess)")
    if status == NONFINITE_START:
        return ILQRError(f"the initial guess us0 has a non-finite cost ({cost}); start from smaller controls")
    if status in (INDEFINITE, NO_DECREASE):
        why = ("the control Hessian Q_uu stayed indefinite" if status == INDEFINITE
               else "no step along the regularised direction decreased the cost")
        return ILQRError(f"iLQR failed: {why} up to regularisation mu = {settings.reg_max:g} (relative to the "
                         f"control curvature; cost {cost:.6g}, predicted decrease {relative:.3g} of the cost's "
                         f"magnitude after {steps} steps); the objective is probably unbounded below or not smooth")
    if status == DIVERGED:
        return ILQRError(f"iLQR diverged: after {steps} steps the cost is {cost:.6g}, below the start's "
                         f"{end['start_cost']:.6g} by more than divergence_ratio = {settings.divergence_ratio:g} times "
                         f"the start's scale {end['scale']:.3g} (or a state or control passed divergence_bound); "
                         "the objective is unbounded below (for a legible objective (1 + alpha) J1 - J0, increase "
                         "alpha or shorten the horizon)")
    return ILQRError(f"iLQR did not converge in max_iter = {settings.max_iter} iterations (cost {cost:.6g}, predicted "
                     f"decrease {relative:.3g} of the cost's magnitude); the objective may be unbounded below "
                     "or badly scaled; raise max_iter")


@x64
def rollout(dynamics, x0, us, params=None):
    """States ``x_0..x_N`` (N+1, n) reached from ``x0`` under the controls ``us`` (N, m)."""
    x0, us = check_problem(dynamics, _no_cost, _no_terminal_cost, x0, us, params)
    return np.asarray(kernels(dynamics, _no_cost, _no_terminal_cost).rollout(x0, us, params))


def _no_cost(x, u, params):
    return jax.numpy.zeros(())


def _no_terminal_cost(x, params):
    return jax.numpy.zeros(())


@x64
def trajectory_cost(dynamics, running_cost, terminal_cost, x0, us, params=None):
    """The single-shooting objective ``H_J(u)`` of eq. (6.6): the total cost of the rollout of ``us``."""
    return trajectory_cost_grad(dynamics, running_cost, terminal_cost, x0, us, params)[0]


@x64
def trajectory_cost_grad(dynamics, running_cost, terminal_cost, x0, us, params=None):
    """``(H_J(u), dH_J/du)``: the single-shooting objective and its autodiff gradient (N, m)."""
    x0, us = check_problem(dynamics, running_cost, terminal_cost, x0, us, params)
    value, grad = kernels(dynamics, running_cost, terminal_cost).value_and_grad(us, x0, params)
    return float(value), np.asarray(grad)


@x64
def ilqr(dynamics, running_cost, terminal_cost, x0, us0, params=None, settings=None, **changes):
    """Minimise the total cost from ``x0`` by iLQR, starting from the controls ``us0`` (N, m);
    return an :class:`ILQRResult`.

    ``params`` (any pytree) is passed to the three callables. ``settings``: an :class:`ILQRSettings`
    (default: its defaults); keywords change single fields of it (``ilqr(..., max_iter=500)``).
    Converged (all tests scale-free, :mod:`.iteration`) when the model's predicted decrease
    ``1/2 g'H^-1 g`` is at most ``grad_tol**2`` times the objective's magnitude ``M`` (sum of
    absolute stage costs), or when an accepted step lowered the cost by at most ``stall_tol M`` and
    moved no control by more than ``step_tol`` times the largest control, or when only rounding is
    left; the point must then be a local minimum (the exact Hessian in the controls positive
    definite), not a saddle. Raises :class:`ILQRError` when it is not, when the regularisation
    needed exceeds ``reg_max`` (relative to the control curvature), when the cost falls below the
    start's by more than ``divergence_ratio`` times the start's scale (or, if ``divergence_bound``
    is given, a state or control exceeds it), or after ``max_iter`` backward passes.
    A stationary point that is not a minimum is left along the exact Hessian's most negative
    curvature and the solve goes on, at most ``SADDLE_ESCAPES`` times, before it is reported.
    ``second_order``: False for Gauss-Newton iLQR, True for full DDP, ``"auto"`` (default)
    Gauss-Newton far from the minimum and DDP close to it (:mod:`.iteration`).
    ``target``: also stop at the first accepted step whose cost is at most ``target`` (NLopt's
    ``stopval``; e.g. a known optimum plus a tolerance, to time solvers to equal cost).
    """
    settings = _settings(settings, changes, DEFAULT)
    x0, us = check_problem(dynamics, running_cost, terminal_cost, x0, us0, params)
    solve = kernels(dynamics, running_cost, terminal_cost).solve
    for _ in range(SADDLE_ESCAPES + 1):
        out = _host(solve(x0, us, params, settings.tolerances, settings.second_order, settings.max_iter))
        outcome = _outcome(*out, settings)
        if not isinstance(outcome, _SaddleError):
            break
        # a saddle (the regularised model can hide negative curvature): step off along it and go on
        us = _escape_saddle(dynamics, running_cost, terminal_cost, x0, out[1], params)
        if us is None:
            break
    if isinstance(outcome, ILQRError):
        raise outcome
    return outcome


@dataclass(frozen=True, repr=False)
class ILQRBatch:
    """The outcome of :func:`ilqr_batch`: ``results[i]`` an :class:`ILQRResult` or None,
    ``errors[i]`` None or the :class:`ILQRError` message of problem ``i``; ``costs`` (B,) the
    final costs (NaN where a problem failed)."""

    results: tuple
    errors: tuple

    @property
    def costs(self):
        return np.array([np.nan if r is None else r.cost for r in self.results])

    @property
    def converged(self):
        return np.array([r is not None for r in self.results])

    def __len__(self):
        return len(self.results)

    def __getitem__(self, i):
        """Problem ``i``'s result; raises its :class:`ILQRError` if it failed."""
        if self.results[i] is None:
            raise ILQRError(self.errors[i])
        return self.results[i]

    def __repr__(self):
        ok = self.converged
        best = f", best cost {np.nanmin(self.costs):.6g}" if ok.any() else ""
        return f"ILQRBatch({len(self)} problems, {int(ok.sum())} converged{best})"


@x64
def ilqr_batch(dynamics, running_cost, terminal_cost, x0, us0, params=None, settings=None, **changes):
    """Solve ``B`` problems at once (:func:`ilqr`'s compiled passes under ``jax.vmap``, same tests).

    ``x0`` (B, n) start states, ``us0`` (B, N, m) initial controls and ``params`` a pytree whose
    every leaf has a leading axis of length B (e.g. stacked goals, weights or alphas). Each
    member takes the passes it takes alone and its result equals what :func:`ilqr` returns for it
    (without the saddle escapes). A batch of 16 or more shrinks as its members stop, so a few
    slow members run on in a small batch instead of keeping the whole batch busy. Returns an
    :class:`ILQRBatch` (failures are reported per problem, not raised).

    ``settings`` and keywords as for :func:`ilqr`, but the default is Gauss-Newton
    (``second_order=False``, :data:`.settings.BATCH_DEFAULT`); with ``"auto"`` a batched pass computes
    the dynamics' Hessians whenever any member is near its minimum. ``bench/bench_ilqr.py``
    measures batches against the same problems solved one at a time.
    """
    settings = _settings(settings, changes, BATCH_DEFAULT)
    x0, us = check_batch(dynamics, running_cost, terminal_cost, x0, us0, params)
    solve = kernels(dynamics, running_cost, terminal_cost).solve_batch
    xs, us, K, costs, summary = jax.device_get(solve(x0, us, params, settings.tolerances, settings.second_order,
                                                     settings.max_iter))
    outcomes = [_outcome(xs[i], us[i], K[i], costs[i], summary[i], settings) for i in range(len(x0))]
    return ILQRBatch(results=tuple(None if isinstance(o, ILQRError) else o for o in outcomes),
                     errors=tuple(str(o) if isinstance(o, ILQRError) else None for o in outcomes))


@x64
def iteration_flops(dynamics, running_cost, terminal_cost, x0, us, params=None, second_order=False):
    """Floating-point operations of one compiled iLQR run of a single backward pass and line search
    (``max_iter=1``) on this problem, from XLA's static cost analysis of the compiled program: a
    deterministic operation count for comparing objectives (Corollary 6.4.2.1), not a timing."""
    x0, us = check_problem(dynamics, running_cost, terminal_cost, x0, us, params)
    settings = DEFAULT.replace(second_order=second_order, max_iter=1)
    solve = kernels(dynamics, running_cost, terminal_cost).solve
    analysis = solve.lower(x0, us, params, settings.tolerances, settings.second_order, settings.max_iter).compile()
    costs = analysis.cost_analysis()
    costs = costs[0] if isinstance(costs, (list, tuple)) else costs
    return float(costs["flops"])
