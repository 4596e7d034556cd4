"""The compiled iLQR iteration behind :func:`mutual.motion.ilqr.ilqr` (Todorov & Li 2005;
regularisation and line search of Tassa, Erez & Todorov 2012), for eq. (6.4) in discrete time.

One solve is one jit-compiled ``jax.lax.while_loop`` over backward passes, so no Python runs
between iterations; a batch of problems runs the same pass under ``jax.vmap``, in a batch that
shrinks as its members stop (``solve_batch``).

**The backward pass** (Tassa et al. 2012, eqs. (5)-(11)): with ``F = [f_x f_u]`` and the running
cost's gradient ``g`` and Hessian ``H`` in ``z = (x, u)``, a stage's model is ``Q_z = g + F'v``,
``Q_zz = H + F'V F`` (DDP adds ``sum_i v_i f_i''``); the policy ``du = k + K dx`` solves
``(Q_uu + mu c I) [k K] = -[Q_u Q_ux]`` and the cost-to-go ``(v, V)`` is updated with the
unregularised ``Q_uu``. ``d1 = sum k'Q_u`` and ``d2 = sum 1/2 k'Q_uu k`` give the model's
predicted decrease ``-(a d1 + a^2 d2)`` for a step of size ``a``.

**Scale-free tests.** ``M``, the magnitude of the objective (the sum of the absolute stage and
terminal costs), is the scale the cost is known to (its rounding error is ``~eps M``); ``c``, the
largest control curvature of the model, is the scale of the regularisation ``mu``. Both scale
with the objective, so every test below is unchanged when the objective is multiplied by a
constant, and the Newton decrement is also unchanged by a linear change of the controls:

* *relative gradient*: converged when the predicted decrease ``1/2 g'H^-1 g <= grad_tol^2 M``
  (``g`` the gradient in the controls, ``H`` the model's (regularised) Hessian);
* *relative decrease and step*: converged when an accepted step lowered the cost by at most
  ``stall_tol M`` and moved no control by more than ``step_tol`` times the largest control;
* *rounding*: when no step size lowers the cost and the predicted decrease is below
  ``ROUNDING_TOL M``, the point is converged to rounding level (not a failure);
* *divergence*: the cost fell below ``J(u0) - divergence_ratio S``, where ``S`` is the scale of
  the start (``M`` at ``u0``, or the first predicted decrease if larger);
* *regularisation exhausted*: ``mu > reg_max`` (relative to ``c``).

(ZERO) An objective whose optimum costs exactly 0 has no scale of its own (``M -> 0``); there ``M``
is floored at ``eps c``, the cost of changing a control by ``sqrt(eps) ~ 1.5e-8`` of its units.

**Gauss-Newton, DDP, or both.** ``second_order=False`` drops the dynamics' curvature
(Gauss-Newton iLQR: cheap passes, but only linear convergence where that curvature matters, as
for the legible objectives of chapter 7); ``True`` keeps it (DDP: quadratic convergence near a
minimum, but far from it ``Q_uu`` is often indefinite and needs heavy regularisation); ``"auto"``
starts with Gauss-Newton and switches to DDP for good from the first pass whose predicted decrease
is below ``SWITCH_TO_DDP M`` or that follows a Gauss-Newton step the line search had to shorten
(its model proved poor). The choice of rule was measured on the Fig. 7.2 problems and a sweep of
64 legible weights (total passes: Gauss-Newton 1588, DDP 1351, this rule 734).
"""

from functools import lru_cache

import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.linalg import cho_solve

STEP_SIZES = 0.5 ** np.arange(11)  # backtracking line search 1, 1/2, ..., 1/1024
ARMIJO = 1e-4  # accept a step whose actual decrease is at least this fraction of the predicted one
MU_MIN, DELTA0 = 1e-6, 2.0  # Tassa et al. (2012): smallest nonzero mu (relative to c), growth factor of mu
SWITCH_TO_DDP = 1e-3  # second_order="auto": DDP once the predicted decrease is below this fraction of M
ROUNDING_TOL = 1e-9  # a predicted decrease below this fraction of M that no step realises is rounding
EPS = float(np.finfo(float).eps)  # M is floored at EPS c: a cost that is exactly 0 (ZERO)
UNROLLED_CHOLESKY_MAX_M = 4  # up to this many controls, Q_uu is factorised by unrolled arithmetic
BACKWARD_UNROLL = 4  # stages per iteration of the backward scan (fewer loop trips; measured on a CPU)
SHRINK_FROM = 16  # a batch of fewer problems runs to its end (a smaller one would cost another compilation)
RUNNING, CONVERGED, NONFINITE_START, INDEFINITE, NO_DECREASE, DIVERGED = range(6)
# the scalars a solve returns, in one array
SUMMARY = ("status", "steps", "passes", "decrease", "magnitude", "step", "mu", "minimum", "start_cost", "scale")


def spd_solve(A, B):
    """``(A^-1 B, ok)`` by the Cholesky factorisation ``A = L L'``; ``ok`` is False (and the
    solution not finite) unless ``A`` (m, m) is positive definite, i.e. every pivot is > 0.

    For ``m <= UNROLLED_CHOLESKY_MAX_M`` the recursion and both triangular substitutions are
    unrolled into plain arithmetic at trace time (inside the backward scan several times faster
    on a CPU than LAPACK's opaque calls); larger ``m`` use LAPACK.
    """
    m = A.shape[-1]
    if m > UNROLLED_CHOLESKY_MAX_M:
        L = jnp.linalg.cholesky(A)  # NaN unless positive definite
        return cho_solve((L, True), B), jnp.all(jnp.isfinite(L))
    if m == 1:
        return B / A[0, 0], A[0, 0] > 0
    L, pivots = [], []
    for i in range(m):
        row = []
        for j in range(i):
            row.append((A[i, j] - sum(row[p] * L[j][p] for p in range(j))) / L[j][j])
        pivots.append(A[i, i] - sum(r * r for r in row))
        row.append(jnp.sqrt(pivots[-1]))  # NaN for a negative pivot
        L.append(row)
    Y = []
    for i in range(m):
        Y.append((B[i] - sum(L[i][p] * Y[p] for p in range(i))) / L[i][i])
    X = [None] * m
    for i in reversed(range(m)):
        X[i] = (Y[i] - sum(L[p][i] * X[p] for p in range(i + 1, m))) / L[i][i]
    return jnp.stack(X), jnp.all(jnp.stack(pivots) > 0)


def _where(flag, new, state):
    """``new`` where ``flag`` holds, else the same entries of ``state`` (dicts of arrays)."""
    return {key: jnp.where(flag, value, state[key]) for key, value in new.items()}


@jax.jit
def _take(tree, index):
    return jax.tree_util.tree_map(lambda a: a[index], tree)


@jax.jit
def _put(tree, index, values):
    return jax.tree_util.tree_map(lambda a, b: a.at[index].set(b), tree, values)


@lru_cache(maxsize=64)
def kernels(dynamics, running_cost, terminal_cost):
    """Compiled ``(rollout, value_and_grad, solve, solve_batch, hessian)`` for one problem's callables.

    ``rollout(x0, us, params)``; ``value_and_grad(us, x0, params)`` of the single-shooting cost;
    ``solve(x0, us, params, tol, second_order, max_iter)`` (one jit-compiled loop); ``solve_batch``
    the same for a batch (a leading axis on ``x0``, ``us`` and ``params``), compiled passes over a
    batch that shrinks as its members stop.
    """

    def rollout(x0, us, params):
        def step(x, u):
            x_next = dynamics(x, u, params)
            return x_next, x_next
        return jnp.concatenate([x0[None], jax.lax.scan(step, x0, us)[1]])

    def cost_and_magnitude(xs, us, params):
        running = jax.vmap(running_cost, in_axes=(0, 0, None))(xs[:-1], us, params)
        final = terminal_cost(xs[-1], params)
        return jnp.sum(running) + final, jnp.sum(jnp.abs(running)) + jnp.abs(final)

    def shooting_cost(us, x0, params):
        return cost_and_magnitude(rollout(x0, us, params), us, params)[0]

    def model(xs, us, params, second_order, near=True):
        """Stacked stage derivatives in ``z = (x, u)``: the dynamics' Jacobian ``F`` (N, n, n+m), the
        running cost's gradient ``g`` (N, n+m) and Hessian ``H`` (N, n+m, n+m), DDP's dynamics
        curvature (N, n, n+m, n+m) or None, the terminal ``(v, V)`` and the curvature scale ``c``."""
        n = xs.shape[1]
        xu = jnp.concatenate([xs[:-1], us], axis=1)

        def f(z):
            return dynamics(z[:n], z[n:], params)

        def ell(z):
            return running_cost(z[:n], z[n:], params)

        F = jax.vmap(jax.jacfwd(f))(xu)
        g = jax.vmap(jax.grad(ell))(xu)
        H = jax.vmap(jax.hessian(ell))(xu)
        vN = jax.grad(terminal_cost)(xs[-1], params)
        VN = jax.hessian(terminal_cost)(xs[-1], params)
        curvature = None
        if second_order:  # computed only where it is used (``near``: the DDP phase of "auto")
            shape = (xu.shape[0], n, xu.shape[1], xu.shape[1])
            curvature = jax.lax.cond(near, lambda: jax.vmap(jax.hessian(f))(xu), lambda: jnp.zeros(shape))
        fu2 = jnp.max(jnp.abs(F[:, :, n:])) ** 2
        c = jnp.maximum(jnp.max(jnp.abs(H[:, n:, n:])),
                        fu2 * jnp.maximum(jnp.max(jnp.abs(VN)), jnp.max(jnp.abs(H[:, :n, :n]))))
        return F, g, H, curvature, vN, VN, jnp.where(c > 0, c, 1.0)

    def backward(blocks, mu, curvature_weight=1.0):
        """Gains ``G = [k K]`` (N, m, 1+n), the predicted terms ``d1 = sum k'Q_u`` and
        ``d2 = sum 1/2 k'Q_uu k``, and whether every ``Q_uu + mu c I`` was positive definite.

        Small products are written as broadcast multiply-and-sum, which XLA fuses inside the
        scan (on a CPU fewer kernels per stage than ``dot``s of 3x3 matrices)."""
        F, g, H, curvature, vN, VN, c = blocks
        n = VN.shape[0]
        m = H.shape[-1] - n
        reg = mu * c * jnp.eye(m)

        def step(carry, stage):
            V, v, d1, d2, every_ok = carry
            Fk, gk, Hk = stage[:3]
            VF = jnp.sum(V[:, :, None] * Fk[None, :, :], axis=1)  # V F (n, n+m)
            Z = Hk + jnp.sum(Fk[:, :, None] * VF[:, None, :], axis=0)  # H + F'V F
            q = gk + jnp.sum(Fk * v[:, None], axis=0)  # g + F'v
            if curvature is not None:
                Z = Z + curvature_weight * jnp.sum(v[:, None, None] * stage[3], axis=0)
            Qxx, Qux, Quu = Z[:n, :n], Z[n:, :n], Z[n:, n:]
            Qx, Qu = q[:n], q[n:]
            G, ok = spd_solve(Quu + reg, -jnp.concatenate([Qu[:, None], Qux], axis=1))
            k, K = G[:, 0], G[:, 1:]
            QuuK = jnp.sum(Quu[:, :, None] * K[None, :, :], axis=1)  # (m, n)
            QuxK = jnp.sum(Qux[:, :, None] * K[:, None, :], axis=0)  # Qux'K (n, n)
            V = Qxx + QuxK + QuxK.T + jnp.sum(K[:, :, None] * QuuK[:, None, :], axis=0)
            V = 0.5 * (V + V.T)
            Quuk = jnp.sum(Quu * k[None, :], axis=1)
            v = Qx + jnp.sum(K * (Quuk + Qu)[:, None], axis=0) + jnp.sum(Qux * k[:, None], axis=0)
            return (V, v, d1 + jnp.sum(k * Qu), d2 + 0.5 * jnp.sum(k * Quuk), every_ok & ok), G

        stages = (F, g, H) if curvature is None else (F, g, H, curvature)
        zero = jnp.zeros(())
        (_, _, d1, d2, ok), G = jax.lax.scan(step, (VN, vN, zero, zero, jnp.ones((), bool)), stages, reverse=True,
                                             unroll=BACKWARD_UNROLL)
        return G, d1, d2, ok

    def line_search(x0, xs, us, cost, G, d1, d2, params, active):
        """Backtracking: roll out ``u + a k + K dx`` for ``a = 1, 1/2, ...`` until the Armijo test passes
        (only while ``active``: under ``vmap`` both branches of the caller's ``cond`` run, and a
        member that is not searching must not keep the batch's search going)."""
        def trial(a):
            def step(x, stage):
                x_ref, u_ref, Gk = stage
                u = u_ref + a * Gk[:, 0] + jnp.sum(Gk[:, 1:] * (x - x_ref)[None, :], axis=1)
                x_next = dynamics(x, u, params)
                return x_next, (x_next, u)
            _, (x_new, u_new) = jax.lax.scan(step, x0, (xs[:-1], us, G))
            x_new = jnp.concatenate([x0[None], x_new])
            c_new, mag_new = cost_and_magnitude(x_new, u_new, params)
            expected = -(a * d1 + a ** 2 * d2)
            accept = jnp.isfinite(c_new) & (c_new < cost) & (cost - c_new >= ARMIJO * expected)
            return x_new, u_new, c_new, mag_new, accept

        steps = jnp.asarray(STEP_SIZES)

        def body(state):
            i, *_ = state
            return (i + 1, *trial(steps[i]))

        def keep_going(state):
            return active & ~state[-1] & (state[0] < len(STEP_SIZES))

        i, x_new, u_new, c_new, mag_new, accept = jax.lax.while_loop(keep_going, body, (1, *trial(steps[0])))
        return x_new, u_new, c_new, mag_new, accept, steps[i - 1]

    def no_step(x0, xs, us, cost, *_):
        return xs, us, cost, jnp.zeros(()), jnp.zeros((), bool), jnp.zeros(())

    def is_minimum(xs, us, params):
        """Whether every exact (DDP) ``Q_uu + 1e-8 c I`` is positive definite: the block
        factorisation of the Hessian of the cost in the controls, so True at a local minimum (up
        to a relative 1e-8 for flat directions) and False at a saddle or maximum."""
        return backward(model(xs, us, params, True), 1e-8)[3]

    def initial(x0, us, params, max_iter):
        """The state of a solve before its first pass (a dict of arrays)."""
        xs = rollout(x0, us, params)
        cost, mag = cost_and_magnitude(xs, us, params)
        n, m, N = xs.shape[1], us.shape[1], us.shape[0]
        count, real = jnp.zeros((), jnp.int32), jnp.zeros(())
        return dict(xs=xs, us=us, G=jnp.zeros((N, m, 1 + n)), cost=cost, mag=mag,
                    costs=jnp.full(max_iter + 1, jnp.nan).at[0].set(cost), steps=count, passes=count,
                    mu=real, delta=real + 1.0, decrease=real + jnp.nan, step=real + jnp.nan, scale=mag,
                    certified=jnp.zeros((), bool), size=real + 1.0, ddp=jnp.zeros((), bool),
                    status=jnp.where(jnp.isfinite(cost), RUNNING, NONFINITE_START).astype(jnp.int32))

    def is_near(s, second_order):
        """Whether this pass keeps the dynamics' curvature (DDP)."""
        if second_order == "auto":  # Gauss-Newton far from the optimum, DDP close to it
            # DDP from the first pass that is close (small predicted decrease) or that follows a
            # Gauss-Newton step that had to be shortened (its model proved poor), and on
            return s["ddp"] | (s["decrease"] <= SWITCH_TO_DDP * s["mag"]) | (s["size"] < 1)
        return jnp.asarray(bool(second_order))

    def iteration(s, x0, params, tol, second_order, any_near=None):
        """One backward pass, line search and test: the next state of a running solve.
        ``any_near``: whether any member of a batch needs the curvature (computed only then)."""
        near = is_near(s, second_order)
        blocks = model(s["xs"], s["us"], params, bool(second_order), near if any_near is None else any_near)
        G, d1, d2, pd = backward(blocks, s["mu"], jnp.where(near, 1.0, 0.0))
        decrease = -(d1 + d2)
        mag = jnp.maximum(s["mag"], EPS * blocks[-1])  # a cost that is exactly 0 (see ZERO below)
        scale = jnp.where((s["passes"] == 0) & pd, jnp.maximum(s["scale"], decrease), s["scale"])
        stationary = pd & (decrease <= tol["grad_tol"] ** 2 * mag)
        search = pd & ~stationary
        x_new, u_new, c_new, mag_new, found, size = jax.lax.cond(
            search, line_search, no_step, x0, s["xs"], s["us"], s["cost"], G, d1, d2, params, search)
        accepted = found & search
        rounding = search & ~found & (decrease <= ROUNDING_TOL * mag)
        # Tassa et al. (2012): a rejected pass raises mu (and its growth), an accepted one lowers them
        delta_up = jnp.maximum(DELTA0, s["delta"] * DELTA0)
        mu_up = jnp.maximum(MU_MIN, s["mu"] * delta_up)
        delta_down = jnp.minimum(1 / DELTA0, s["delta"] / DELTA0)
        mu_down = jnp.where(s["mu"] * delta_down > MU_MIN, s["mu"] * delta_down, 0.0)
        step = jnp.max(jnp.abs(u_new - s["us"]))
        largest = jnp.maximum(jnp.max(jnp.abs(u_new)), jnp.max(jnp.abs(s["us"])))
        stalled = ((s["cost"] - c_new <= tol["stall_tol"] * jnp.maximum(mag_new, EPS * blocks[-1]))
                   & (step <= tol["step_tol"] * largest))
        runaway = (c_new < s["costs"][0] - tol["divergence_ratio"] * scale) | ~(
            jnp.maximum(jnp.max(jnp.abs(x_new)), jnp.max(jnp.abs(u_new))) <= tol["divergence_bound"])
        status = jnp.select(
            [stationary | rounding,
             ~accepted & (mu_up > tol["reg_max"]),
             accepted & runaway,
             accepted & (stalled | (c_new <= tol["target"]))],
            [CONVERGED, jnp.where(pd, NO_DECREASE, INDEFINITE), DIVERGED, CONVERGED], RUNNING)
        new = dict(xs=x_new, us=u_new, cost=c_new, mag=mag_new, steps=s["steps"] + 1,
                   costs=s["costs"].at[s["steps"] + 1].set(c_new), step=step, size=size)
        reg = dict(mu=jnp.where(accepted, mu_down, mu_up), delta=jnp.where(accepted, delta_down, delta_up))
        return {**s, **_where(accepted, new, s), **_where(status.astype(jnp.int32) == RUNNING, reg, s),
                "G": G, "passes": s["passes"] + 1, "decrease": decrease, "scale": scale,
                "certified": pd & near & (s["mu"] == 0), "ddp": near,
                "status": status.astype(jnp.int32)}

    def running(s, max_iter):
        return (s["status"] == RUNNING) & (s["passes"] < max_iter)

    def finish(end, params):
        """``xs, us, K, costs`` (the accepted costs are ``costs[:steps + 1]``) and the scalars of
        ``SUMMARY`` in one array, once a solve has stopped."""
        # a last exact (DDP) pass at mu = 0 that was positive definite already certified the minimum
        end = dict(end, minimum=jax.lax.cond((end["status"] == CONVERGED) & ~end["certified"], is_minimum,
                                             lambda *_: end["certified"], end["xs"], end["us"], params))
        end["magnitude"], end["start_cost"] = end["mag"], end["costs"][0]
        summary = jnp.stack([end[key].astype(float) for key in SUMMARY])
        return end["xs"], end["us"], end["G"][:, :, 1:], end["costs"], summary

    def solve(x0, us, params, tol, second_order, max_iter):
        """iLQR to convergence as one ``while_loop`` over backward passes.

        ``tol`` holds ``grad_tol``, ``stall_tol``, ``step_tol``, ``reg_max``, ``divergence_ratio``,
        ``divergence_bound`` (inf: off) and ``target`` (-inf: off). Returns what :func:`finish` returns.
        """
        end = jax.lax.while_loop(lambda s: running(s, max_iter),
                                 lambda s: iteration(s, x0, params, tol, second_order), initial(x0, us, params, max_iter))
        return finish(end, params)

    def advance(states, x0, params, tol, second_order, max_iter, keep):
        """Passes of a batch of solves (leading axis) until at most ``keep`` of them still run.

        A member that has stopped keeps its state while the others go on; the loop ends for the
        whole batch once few enough run, so the caller can gather the rest into a smaller batch."""
        step = jax.vmap(iteration, in_axes=(0, 0, 0, None, None, None))

        def body(states):
            on = running(states, max_iter)
            any_near = jnp.any(jax.vmap(is_near, in_axes=(0, None))(states, second_order) & on)
            new = step(states, x0, params, tol, second_order, any_near)
            return jax.tree_util.tree_map(lambda a, b: jnp.where(on.reshape(on.shape + (1,) * (a.ndim - 1)), a, b),
                                          new, states)

        def go_on(states):
            on = running(states, max_iter)
            return jnp.any(on) & (jnp.sum(on) > keep)
        return jax.lax.while_loop(go_on, body, states)

    start_batch = jax.jit(jax.vmap(initial, in_axes=(0, 0, 0, None)), static_argnums=3)
    advance_batch = jax.jit(advance, static_argnums=(4, 5))
    finish_batch = jax.jit(jax.vmap(finish))

    def solve_batch(x0, us, params, tol, second_order, max_iter):
        """:func:`solve` for a batch (leading axis on ``x0``, ``us`` and every leaf of ``params``).

        A batch of at least ``SHRINK_FROM`` problems shrinks as its members stop: once at most a
        quarter of it still runs, those members are gathered into a batch whose size is a power of
        4 (padded with repeats) and go on there, so a few slow members do not keep the whole batch
        busy (a vmapped pass costs the same however many of its members still run). Gathering
        moves whole states, so every member takes the same passes as alone."""
        states = start_batch(x0, us, params, max_iter)
        live = np.arange(len(x0))
        size = live.size
        while live.size:
            pick = np.concatenate([live, np.repeat(live[:1], size - live.size)])
            part = (states, x0, params) if size == len(x0) else _take((states, x0, params), pick)
            done = advance_batch(*part, tol, second_order, max_iter, size // 4 if size >= SHRINK_FROM else 0)
            states = done if size == len(x0) else _put(states, pick, done)
            live = live[np.asarray(running(done, max_iter))[:live.size]]
            size = 4 ** int(np.ceil(np.log(max(live.size, 1)) / np.log(4) - 1e-9))
        return finish_batch(states, params)

    def hessian(us, x0, params):
        """The exact Hessian of the single-shooting cost in the stacked controls (N m, N m)."""
        shape = us.shape
        return jax.hessian(lambda flat: shooting_cost(flat.reshape(shape), x0, params))(us.ravel())

    return (jax.jit(rollout), jax.jit(jax.value_and_grad(shooting_cost)),
            jax.jit(solve, static_argnames=("second_order", "max_iter")), solve_batch, jax.jit(hessian))
