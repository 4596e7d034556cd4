"""Iterative LQR (Todorov & Li 2005) with Tassa-style regularisation, for eq. (6.4) in discrete time.

The problem, with ``x_0`` given and the horizon ``N`` set by the control sequence::

    min_u  sum_{k<N} running_cost(x_k, u_k, params) + terminal_cost(x_N, params)
    s.t.   x_{k+1} = dynamics(x_k, u_k, params)

The three callables are written with ``jax.numpy``; their derivatives come from
JAX autodiff (exact, no finite differences). The whole solve, every iteration and
the final check, is one jit-compiled ``jax.lax.while_loop`` per set of callables
(``params`` is traced, so a family of problems shares one compilation): no Python
runs between iterations and the result reaches the host in one transfer. All
arithmetic is float64.

Each iteration linearises the dynamics and takes a second-order model of the cost
along the current trajectory (vmapped over the stages; Gauss-Newton: the dynamics'
curvature is dropped; ``second_order=True`` keeps it, which is full DDP as in Tassa
et al. and converges faster when the cost-to-go gradient is large, e.g. for a goal
just out of reach), runs the Riccati-like backward pass for an affine policy
``du = k + K dx`` (a ``jax.lax.scan``), and rolls the policy out with a backtracking
line search (step sizes 1, 1/2, ..., 1/1024 until the Armijo test passes; the first
step is almost always accepted, so the trials run one after another rather than
vmapped, which on a CPU would cost the work of all of them). Objectives need not be
convex, e.g. the legible ``(1 + alpha) J1 - J0`` of eq. (6.15): the control block
``Q_uu`` of the model is regularised to ``Q_uu + mu I`` with the schedule of Tassa,
Erez & Todorov (2012) whenever it is not positive definite.

An objective that is unbounded below, or a run that diverges, raises
:class:`ILQRError` with the reason (regularisation exhausted, trajectory or cost
blowing up, no convergence), instead of returning a meaningless trajectory.
"""

from dataclasses import dataclass
from functools import lru_cache, wraps

import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.linalg import cho_solve

STEP_SIZES = 0.5 ** np.arange(11)  # backtracking line search 1, 1/2, ..., 1/1024
ARMIJO = 1e-4  # accept a step whose actual decrease is at least this fraction of the predicted one
MU_MIN, DELTA0 = 1e-6, 2.0  # Tassa et al. (2012): smallest nonzero regularisation mu, growth factor of mu
UNROLLED_CHOLESKY_MAX_M = 4  # up to this many controls, Q_uu is factorised by unrolled arithmetic (see _spd_solve)
# how a solve ended (the status the compiled loop reports)
RUNNING, CONVERGED, NONFINITE_START, INDEFINITE, NO_DECREASE, DIVERGED = range(6)
SUMMARY = ("status", "steps", "grad", "size", "mu", "minimum")  # the scalars a solve returns


class ILQRError(RuntimeError):
    """iLQR could not find a local minimum: the objective is unbounded below or the run diverged."""


@dataclass(frozen=True)
class ILQRResult:
    """A converged iLQR solution.

    ``xs`` (N+1, n) states, ``us`` (N, m) controls, ``K`` (N, m, n) the feedback gains
    of the last backward pass, ``cost`` the objective, ``iterations`` the number of
    accepted steps, ``costs`` the objective after each of them (starting with the
    initial guess), ``reg`` the regularisation ``mu`` of the last backward pass.
    """

    xs: np.ndarray
    us: np.ndarray
    K: np.ndarray
    cost: float
    iterations: int
    costs: np.ndarray
    reg: float


def _x64(fn):
    """Run ``fn`` (and everything it traces or compiles) with 64-bit JAX types, leaving the
    global JAX setting of other modules alone."""
    @wraps(fn)
    def wrapped(*args, **kwargs):
        with jax.enable_x64(True):
            return fn(*args, **kwargs)
    return wrapped


def _spd_solve(A, B):
    """``(A^-1 B, ok)`` by the Cholesky factorisation ``A = L L^T``; ``ok`` is False (and the
    solution not finite) unless ``A`` (m, m) is positive definite, i.e. every pivot is > 0.

    For ``m <= UNROLLED_CHOLESKY_MAX_M`` the Cholesky-Banachiewicz recursion and the two
    triangular substitutions are unrolled into plain arithmetic at trace time: inside the
    backward pass's scan this is several times faster on a CPU than LAPACK's ``potrf``
    and ``trsm``, which are opaque calls with a fixed cost per stage. Larger ``m`` use LAPACK.
    """
    m = A.shape[-1]
    if m > UNROLLED_CHOLESKY_MAX_M:
        L = jnp.linalg.cholesky(A)  # NaN unless positive definite
        return cho_solve((L, True), B), jnp.all(jnp.isfinite(L))
    L, pivots = [], []  # L[i][j], j <= i, as scalars
    for i in range(m):
        row = []
        for j in range(i):
            row.append((A[i, j] - sum(row[p] * L[j][p] for p in range(j))) / L[j][j])
        pivots.append(A[i, i] - sum(r * r for r in row))
        row.append(jnp.sqrt(pivots[-1]))  # NaN for a negative pivot
        L.append(row)
    Y = []  # L Y = B
    for i in range(m):
        Y.append((B[i] - sum(L[i][p] * Y[p] for p in range(i))) / L[i][i])
    X = [None] * m  # L^T X = Y
    for i in reversed(range(m)):
        X[i] = (Y[i] - sum(L[p][i] * X[p] for p in range(i + 1, m))) / L[i][i]
    return jnp.stack(X), jnp.all(jnp.stack(pivots) > 0)


def _where(flag, new, state):
    """``new`` where ``flag`` holds, else the same entries of ``state`` (dicts of arrays)."""
    return {key: jnp.where(flag, value, state[key]) for key, value in new.items()}


@lru_cache(maxsize=64)
def _kernels(dynamics, running_cost, terminal_cost):
    """Jit-compiled rollout, single-shooting cost and gradient, and the whole iLQR solve for one problem."""

    def rollout(x0, us, params):
        def step(x, u):
            x_next = dynamics(x, u, params)
            return x_next, x_next
        _, xs = jax.lax.scan(step, x0, us)
        return jnp.concatenate([x0[None], xs])

    def total_cost(xs, us, params):
        running = jax.vmap(running_cost, in_axes=(0, 0, None))(xs[:-1], us, params)
        return jnp.sum(running) + terminal_cost(xs[-1], params)

    STEP_SIZES_J = jnp.asarray(STEP_SIZES)

    def shooting_cost(us, x0, params):
        return total_cost(rollout(x0, us, params), us, params)

    def quadratic_model(xs, us, params, second_order):
        """Per-stage derivatives; ``second_order`` adds the dynamics' curvature (DDP)."""
        x, u = xs[:-1], us
        batch = dict(in_axes=(0, 0, None))
        fx, fu = jax.vmap(jax.jacfwd(dynamics, (0, 1)), **batch)(x, u, params)
        lx, lu = jax.vmap(jax.grad(running_cost, (0, 1)), **batch)(x, u, params)
        (lxx, _), (lux, luu) = jax.vmap(jax.hessian(running_cost, (0, 1)), **batch)(x, u, params)
        curvature = (jax.vmap(jax.hessian(dynamics, (0, 1)), **batch)(x, u, params) if second_order
                     else ((None, None), (None, None)))
        (fxx, _), (fux, fuu) = curvature
        Vx = jax.grad(terminal_cost)(xs[-1], params)
        Vxx = jax.hessian(terminal_cost)(xs[-1], params)
        return (fx, fu, lx, lu, lxx, lux, luu, fxx, fux, fuu), (Vx, Vxx)

    def backward(model, terminal, mu, second_order, shift=0.0):
        """Backward pass: gains, predicted decrease terms, the largest gradient entry, and whether
        every ``Q_uu + (mu + shift (1 + max|Q_uu|)) I`` was positive definite."""
        m = model[1].shape[-1]

        def step(carry, stage):
            Vx, Vxx, lam = carry
            fx, fu, lx, lu, lxx, lux, luu, fxx, fux, fuu = stage
            grad = lu + fu.T @ lam  # exact gradient dJ/du_k by the adjoint recursion
            Qx = lx + fx.T @ Vx
            Qu = lu + fu.T @ Vx
            Qxx = lxx + fx.T @ Vxx @ fx
            Quu = luu + fu.T @ Vxx @ fu
            Qux = lux + fu.T @ Vxx @ fx
            if second_order:
                Qxx, Quu, Qux = (Q + jnp.tensordot(Vx, f, 1) for Q, f in ((Qxx, fxx), (Quu, fuu), (Qux, fux)))
            Quu = 0.5 * (Quu + Quu.T)
            gains, ok = _spd_solve(Quu + (mu + shift * (1.0 + jnp.max(jnp.abs(Quu)))) * jnp.eye(m),
                                   -jnp.concatenate([Qu[:, None], Qux], axis=1))
            k, K = gains[:, 0], gains[:, 1:]
            Vx = Qx + K.T @ Quu @ k + K.T @ Qu + Qux.T @ k
            Vxx = Qxx + K.T @ Quu @ K + K.T @ Qux + Qux.T @ K
            lam = lx + fx.T @ lam
            return (Vx, 0.5 * (Vxx + Vxx.T), lam), (k, K, k @ Qu, 0.5 * k @ Quu @ k, ok, grad)

        Vx, Vxx = terminal
        _, (k, K, d1, d2, ok, grad) = jax.lax.scan(step, (Vx, Vxx, Vx), model, reverse=True)
        return k, K, jnp.sum(d1), jnp.sum(d2), jnp.all(ok), jnp.max(jnp.abs(grad))

    def line_search(x0, xs, us, cost, k, K, d1, d2, params):
        """Backtracking: roll out ``u + a k + K dx`` for ``a = 1, 1/2, ...`` until the Armijo test passes."""
        def trial(a):
            def step(x, stage):
                x_ref, u_ref, kk, KK = stage
                u = u_ref + a * kk + KK @ (x - x_ref)
                x_next = dynamics(x, u, params)
                return x_next, (x_next, u)
            _, (x_new, u_new) = jax.lax.scan(step, x0, (xs[:-1], us, k, K))
            x_new = jnp.concatenate([x0[None], x_new])
            c_new = total_cost(x_new, u_new, params)
            accept = jnp.isfinite(c_new) & (cost - c_new >= -ARMIJO * (a * d1 + a ** 2 * d2))
            return x_new, u_new, c_new, accept

        def body(state):
            i, *_ = state
            return (i + 1, *trial(STEP_SIZES_J[i]))

        def keep_going(state):
            i, _, _, _, accept = state
            return (~accept) & (i < len(STEP_SIZES))

        first = (1, *trial(STEP_SIZES_J[0]))
        _, x_new, u_new, c_new, accept = jax.lax.while_loop(keep_going, body, first)
        return x_new, u_new, c_new, accept

    def is_minimum(xs, us, params):
        """Whether the exact (DDP) ``Q_uu`` are all positive definite up to a relative 1e-8:
        the block factorisation of the Hessian of the cost in the controls, so True at a strict
        local minimum and False at a saddle or maximum."""
        return backward(*quadratic_model(xs, us, params, True), 0.0, True, shift=1e-8)[4]

    def solve(x0, us, params, tol, second_order, max_iter):
        """iLQR to convergence (see :func:`ilqr`) as one ``while_loop`` over backward passes.

        ``tol`` holds ``grad_tol``, ``stall_tol``, ``reg_max`` and ``divergence_bound``. Returns
        ``xs, us, K, costs`` (the accepted costs are ``costs[:steps + 1]``) and, in one array so
        that they reach the host in one transfer, the scalars of ``SUMMARY``: the status (RUNNING
        when ``max_iter`` passes ran out), the number of accepted steps, the last pass's largest
        gradient entry, the size of the last step, ``mu``, and whether a converged point is a
        local minimum.
        """
        xs = rollout(x0, us, params)
        cost = total_cost(xs, us, params)
        n, m = xs.shape[1], us.shape[1]
        count, real = jnp.zeros((), jnp.int32), jnp.zeros(())
        start = dict(xs=xs, us=us, K=jnp.zeros((us.shape[0], m, n)), cost=cost,
                     costs=jnp.full(max_iter + 1, jnp.nan).at[0].set(cost), steps=count, passes=count,
                     mu=real, delta=real + 1.0, grad=real + jnp.nan, size=real,
                     status=jnp.where(jnp.isfinite(cost), RUNNING, NONFINITE_START).astype(jnp.int32))

        def no_step(x0, xs, us, cost, *_):
            return xs, us, cost, jnp.zeros((), bool)

        def iteration(s):
            """One backward pass and, unless it stops the solve, a line search (Todorov & Li 2005)."""
            k, K, d1, d2, pd, grad = backward(*quadratic_model(s["xs"], s["us"], params, second_order),
                                              s["mu"], second_order)
            scale = 1 + jnp.abs(s["cost"])
            stationary = pd & (grad <= tol["grad_tol"] * scale)
            x_new, u_new, c_new, found = jax.lax.cond(pd & ~stationary, line_search, no_step,
                                                      x0, s["xs"], s["us"], s["cost"], k, K, d1, d2, params)
            accepted = found & pd & ~stationary
            # Tassa et al. (2012): a rejected pass raises mu (and its growth), an accepted one lowers them
            delta_up = jnp.maximum(DELTA0, s["delta"] * DELTA0)
            mu_up = jnp.maximum(MU_MIN, s["mu"] * delta_up)
            delta_down = jnp.minimum(1 / DELTA0, s["delta"] / DELTA0)
            mu_down = jnp.where(s["mu"] * delta_down > MU_MIN, s["mu"] * delta_down, 0.0)
            size = jnp.max(jnp.stack([jnp.max(jnp.abs(x_new)), jnp.max(jnp.abs(u_new)), jnp.abs(c_new)]))
            new_scale = 1 + jnp.abs(c_new)
            stalled = ((s["cost"] - c_new <= tol["stall_tol"] * new_scale)
                       & (grad <= 1e3 * tol["grad_tol"] * new_scale))
            status = jnp.select(
                [stationary,
                 ~accepted & (mu_up > tol["reg_max"]),
                 accepted & ~(size <= tol["divergence_bound"]),  # also when not finite
                 accepted & stalled],
                [CONVERGED, jnp.where(pd, NO_DECREASE, INDEFINITE), DIVERGED, CONVERGED], RUNNING).astype(jnp.int32)
            step = dict(xs=x_new, us=u_new, cost=c_new, steps=s["steps"] + 1,
                        costs=s["costs"].at[s["steps"] + 1].set(c_new))
            reg = dict(mu=jnp.where(accepted, mu_down, mu_up), delta=jnp.where(accepted, delta_down, delta_up))
            # a final pass reports the regularisation it ran with
            return {**s, **_where(accepted, step, s), **_where(status == RUNNING, reg, s),
                    "K": K, "passes": s["passes"] + 1, "grad": grad, "size": size, "status": status}

        def running(s):
            return (s["status"] == RUNNING) & (s["passes"] < max_iter)

        end = jax.lax.while_loop(running, iteration, start)
        end["minimum"] = jax.lax.cond(end["status"] == CONVERGED, is_minimum, lambda *_: jnp.zeros((), bool),
                                      end["xs"], end["us"], params)
        return end["xs"], end["us"], end["K"], end["costs"], jnp.stack([end[key].astype(float) for key in SUMMARY])

    return (jax.jit(rollout), jax.jit(jax.value_and_grad(shooting_cost)),
            jax.jit(solve, static_argnames=("second_order", "max_iter")))


@lru_cache(maxsize=256)
def _check_outputs(dynamics, running_cost, terminal_cost, n, m, treedef, specs):
    """Abstractly evaluate the callables once per problem signature and check their output shapes."""
    x, u = jax.ShapeDtypeStruct((n,), jnp.float64), jax.ShapeDtypeStruct((m,), jnp.float64)
    params = jax.tree_util.tree_unflatten(treedef, [jax.ShapeDtypeStruct(shape, dtype) for shape, dtype in specs])
    out = jax.eval_shape(dynamics, x, u, params).shape
    if out != (n,):
        raise ValueError(f"dynamics must map a state of shape {(n,)} to the same shape, got {out}")
    for name, shape in (("running_cost", jax.eval_shape(running_cost, x, u, params).shape),
                        ("terminal_cost", jax.eval_shape(terminal_cost, x, params).shape)):
        if shape != ():
            raise ValueError(f"{name} must return a scalar, got shape {shape}")


def _check_problem(dynamics, running_cost, terminal_cost, x0, us, params):
    """Validate the inputs and the callables' output shapes up front; return x0 and us as float arrays."""
    for name, fn in (("dynamics", dynamics), ("running_cost", running_cost), ("terminal_cost", terminal_cost)):
        if not callable(fn):
            raise ValueError(f"{name} must be callable, got {type(fn).__name__}")
    x0 = np.asarray(x0, dtype=float)
    us = np.asarray(us, dtype=float)
    if x0.ndim != 1:
        raise ValueError(f"x0 must be a state vector, got shape {x0.shape}")
    if us.ndim != 2 or us.shape[0] < 1:
        raise ValueError(f"us must have shape (N, m) with N >= 1, got {us.shape}")
    if not (np.all(np.isfinite(x0)) and np.all(np.isfinite(us))):
        raise ValueError("x0 and us must be finite")
    leaves, treedef = jax.tree_util.tree_flatten(params)
    specs = tuple((np.shape(leaf), np.result_type(leaf).name) for leaf in leaves)
    _check_outputs(dynamics, running_cost, terminal_cost, x0.shape[0], us.shape[1], treedef, specs)
    return x0, us


@_x64
def rollout(dynamics, x0, us, params=None):
    """States ``x_0..x_N`` (N+1, n) reached from ``x0`` under the controls ``us`` (N, m)."""
    x0, us = _check_problem(dynamics, _no_cost, _no_terminal_cost, x0, us, params)
    return np.asarray(_kernels(dynamics, _no_cost, _no_terminal_cost)[0](x0, us, params))


def _no_cost(x, u, params):
    return jnp.zeros(())


def _no_terminal_cost(x, params):
    return jnp.zeros(())


@_x64
def trajectory_cost(dynamics, running_cost, terminal_cost, x0, us, params=None):
    """The single-shooting objective ``H_J(u)`` of eq. (6.6): the total cost of the rollout of ``us``."""
    return trajectory_cost_grad(dynamics, running_cost, terminal_cost, x0, us, params)[0]


@_x64
def trajectory_cost_grad(dynamics, running_cost, terminal_cost, x0, us, params=None):
    """``(H_J(u), dH_J/du)``: the single-shooting objective and its autodiff gradient (N, m)."""
    x0, us = _check_problem(dynamics, running_cost, terminal_cost, x0, us, params)
    value, grad = _kernels(dynamics, running_cost, terminal_cost)[1](us, x0, params)
    return float(value), np.asarray(grad)


@_x64
def solve_single_shooting(dynamics, running_cost, terminal_cost, x0, us0, params=None, gtol=1e-8,
                          max_iter=20000):
    """Minimise ``H_J(u)`` over the flattened controls with scipy L-BFGS (the baseline to iLQR).

    Uses the same jit-compiled objective and autodiff gradient as iLQR's line search;
    returns ``(us, cost, scipy_result)``.
    """
    from scipy.optimize import minimize

    x0, us0 = _check_problem(dynamics, running_cost, terminal_cost, x0, us0, params)
    value_and_grad = _kernels(dynamics, running_cost, terminal_cost)[1]
    shape = us0.shape
    # on the device once, so that the evaluations do not convert them again at every call
    x0, params = jax.device_put((x0, params))

    def fun(flat):
        value, grad = value_and_grad(flat.reshape(shape), x0, params)
        return float(value), np.asarray(grad, dtype=float).ravel()

    res = minimize(fun, us0.ravel(), jac=True, method="L-BFGS-B",
                   options={"maxiter": max_iter, "maxfun": 2 * max_iter, "gtol": gtol, "ftol": 1e-15})
    return res.x.reshape(shape), float(res.fun), res


@_x64
def ilqr(dynamics, running_cost, terminal_cost, x0, us0, params=None, max_iter=200, grad_tol=1e-9,
         stall_tol=1e-12, reg_max=1e10, divergence_bound=1e6, second_order=False):
    """Minimise the total cost from ``x0`` by iLQR, starting from the controls ``us0`` (N, m);
    return an :class:`ILQRResult`.

    ``params`` (any pytree) is passed to the three callables. Converged when the exact
    gradient ``dJ/du`` (adjoint recursion) is at most ``grad_tol * (1 + |cost|)`` in every
    entry, or when an accepted step improves the cost by less than ``stall_tol * (1 + |cost|)``
    (rounding level) with the gradient within 1000 times that bound; the point must then
    be a local minimum (the exact Hessian in the controls positive definite), not a
    saddle. Raises :class:`ILQRError` when it is not, when the regularisation needed
    exceeds ``reg_max``, when states, controls or the cost exceed ``divergence_bound`` in
    size or become non-finite, or after ``max_iter`` backward passes without convergence.
    ``second_order=True`` runs full DDP instead (see the module docstring).
    """
    if not (isinstance(max_iter, (int, np.integer)) and max_iter >= 1):
        raise ValueError(f"max_iter must be a positive integer, got {max_iter!r}")
    tol = dict(grad_tol=grad_tol, stall_tol=stall_tol, reg_max=reg_max, divergence_bound=divergence_bound)
    for name, value in tol.items():
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    x0, us = _check_problem(dynamics, running_cost, terminal_cost, x0, us0, params)
    solve = _kernels(dynamics, running_cost, terminal_cost)[2]
    xs, us, K, costs, summary = jax.device_get(solve(x0, us, params, {k: float(v) for k, v in tol.items()},
                                                     second_order=bool(second_order), max_iter=int(max_iter)))
    end = dict(zip(SUMMARY, summary.tolist()))
    status, steps, grad = int(end["status"]), int(end["steps"]), end["grad"]
    costs = costs[:steps + 1]
    cost = float(costs[-1])
    if status == CONVERGED and end["minimum"]:
        return ILQRResult(xs=xs, us=us, K=K, cost=cost, iterations=steps, costs=costs, reg=end["mu"])
    if status == CONVERGED:
        raise ILQRError(f"iLQR stopped at a stationary point (cost {cost:.6g}) that is not a local minimum: "
                        "the exact Hessian of the cost in the controls is not positive definite; "
                        "the objective may be unbounded below, or a symmetric start sits on a saddle "
                        "(start from a perturbed guess)")
    if status == NONFINITE_START:
        raise ILQRError(f"the initial guess has a non-finite cost ({cost})")
    if status in (INDEFINITE, NO_DECREASE):
        why = ("the control Hessian Q_uu stayed indefinite" if status == INDEFINITE
               else "no step along the regularised direction decreased the cost")
        raise ILQRError(f"iLQR failed: {why} up to regularisation mu = {reg_max:g} (cost {cost:.6g}, "
                        f"largest gradient entry {grad:.3g} after {steps} steps); "
                        "the objective is probably unbounded below or not smooth")
    if status == DIVERGED:
        raise ILQRError(f"iLQR diverged: after {steps} steps the cost is {cost:.6g} and the largest "
                        f"|state|, |control| or |cost| is {end['size']:.3g} > divergence_bound = "
                        f"{divergence_bound:g}; the objective is unbounded below (for a legible objective "
                        "(1 + alpha) J1 - J0, increase alpha or shorten the horizon)")
    raise ILQRError(f"iLQR did not converge in {max_iter} iterations (cost {cost:.6g}, still falling by "
                    f"{costs[-2] - costs[-1] if steps else float('nan'):.3g} per step, largest "
                    f"gradient entry {grad:.3g}); the objective may be unbounded below or badly scaled")
