"""Legible motion as hypothesis testing for linear-quadratic hypotheses (chapter 6).

An observer decides between hypotheses ``H_i``, each an optimal-control problem
with cost ``J_i`` (eq. (6.3)); it models the robot's controls as Boltzmann
distributed, ``P(u | H_i) = exp(-J_i(u)) / Z_i`` (eq. (6.8)). By Theorem 6.4.2
the likelihood ratio ``Lambda = P(u|H0) / P(u|H1)`` (eq. (6.7)) has the same
minimisers as ``J1 - J0`` (eq. (6.13)); weighting the task, ``(1 + alpha) J1 - J0``
(eq. (6.15)). For linear dynamics and quadratic costs this is one LQ problem,
solved exactly by :func:`mutual.lqr.solve_lq`.

Costs use the convention of :mod:`mutual.lqr`: stage cost ``1/2 x'Qx + q'x +
1/2 u'Ru + r'u``, terminal ``1/2 x'Q_N x + q_N'x``, plus a constant, so that
costs add and scale (``1.5 * J1 - J0``) exactly as hypotheses do in eq. (6.15).
With quadratic costs and linear dynamics ``P(u | H_i)`` is Gaussian in the
stacked controls, so ``Z_i`` and ``Lambda`` have closed forms
(:func:`log_likelihood_ratio`).
"""

from dataclasses import dataclass

import cvxpy as cp
import numpy as np

from .lqr import riccati_backward, solve_lq


@dataclass(frozen=True)
class LinearDynamics:
    """``x_{k+1} = A x_k + B u_k`` (``A`` (n, n) or (N, n, n); ``B`` (n, m) or (N, n, m))."""

    A: np.ndarray
    B: np.ndarray

    def __post_init__(self):
        A, B = np.asarray(self.A, float), np.asarray(self.B, float)
        if A.ndim not in (2, 3) or A.shape[-1] != A.shape[-2]:
            raise ValueError(f"A must be (n, n) or (N, n, n), got shape {A.shape}")
        if B.ndim not in (2, 3) or B.shape[-2] != A.shape[-1]:
            raise ValueError(f"B must be (n, m) or (N, n, m) with n = {A.shape[-1]}, got shape {B.shape}")
        object.__setattr__(self, "A", A)
        object.__setattr__(self, "B", B)

    @property
    def n(self):
        return self.A.shape[-1]

    @property
    def m(self):
        return self.B.shape[-1]

    def stages(self, start, N):
        """The dynamics of stages ``start .. start + N - 1`` (for replanning)."""
        A = self.A[start:start + N] if self.A.ndim == 3 else self.A
        B = self.B[start:start + N] if self.B.ndim == 3 else self.B
        return LinearDynamics(A, B)


def single_integrator(dim=2, dt=0.01):
    """Path-planning dynamics ``x' = u`` (eq. (6.5)), Euler-discretised: ``x_{k+1} = x_k + dt u_k``."""
    if not dt > 0:
        raise ValueError(f"dt must be positive, got {dt!r}")
    if not isinstance(dim, (int, np.integer)) or dim < 1:
        raise ValueError(f"dim must be a positive integer, got {dim!r}")
    return LinearDynamics(np.eye(dim), dt * np.eye(dim))


_FIELDS = ("Q", "q", "R", "r", "QN", "qN")
_STAGE_FIELDS = ("Q", "q", "R", "r")


@dataclass(frozen=True)
class QuadraticCost:
    """A hypothesis cost ``J = sum_k [1/2 x'Qx + q'x + 1/2 u'Ru + r'u] + 1/2 x_N'Q_N x_N + q_N'x_N + const``.

    Stage arrays are time-invariant ((n, n), (n,), ...) or per stage ((N, n, n), ...).
    Costs form a vector space: ``a * J1 - J0`` is again a QuadraticCost (eq. (6.15)).
    """

    Q: np.ndarray
    q: np.ndarray
    R: np.ndarray
    r: np.ndarray
    QN: np.ndarray
    qN: np.ndarray
    const: float = 0.0

    def __post_init__(self):
        for f in _FIELDS:
            object.__setattr__(self, f, np.asarray(getattr(self, f), float))
        n, m = self.QN.shape[0], self.R.shape[-1]
        shapes = {"Q": (n, n), "q": (n,), "R": (m, m), "r": (m,), "QN": (n, n), "qN": (n,)}
        for f, shape in shapes.items():
            a = getattr(self, f)
            per_stage = f in _STAGE_FIELDS and a.ndim == len(shape) + 1
            if a.shape[per_stage:] != shape:
                allowed = f"{shape} or (N, *{shape})" if f in _STAGE_FIELDS else f"{shape}"
                raise ValueError(f"cost field {f} has shape {a.shape}; expected {allowed}")
        object.__setattr__(self, "const", float(self.const))

    def __add__(self, other):
        if not isinstance(other, QuadraticCost):
            return NotImplemented
        return QuadraticCost(*(getattr(self, f) + getattr(other, f) for f in _FIELDS), self.const + other.const)

    def __mul__(self, w):
        w = float(w)
        return QuadraticCost(*(w * getattr(self, f) for f in _FIELDS), w * self.const)

    __rmul__ = __mul__

    def __neg__(self):
        return -1.0 * self

    def __sub__(self, other):
        return self + (-other)

    def _per_stage(self, f):
        return f in _STAGE_FIELDS and getattr(self, f).ndim == (3 if f in ("Q", "R") else 2)

    def stages(self, start, N):
        """The cost of stages ``start .. start + N - 1`` plus the terminal cost (for replanning)."""
        cut = [getattr(self, f)[start:start + N] if self._per_stage(f) else getattr(self, f) for f in _FIELDS]
        return QuadraticCost(*cut, self.const)

    def value(self, xs, us):
        """``J(x, u)`` of a trajectory ``xs`` (N+1, n), ``us`` (N, m)."""
        xs, us = np.asarray(xs, float), np.asarray(us, float)
        N = us.shape[0]
        Q = np.broadcast_to(self.Q, (N, *self.Q.shape[-2:]))
        R = np.broadcast_to(self.R, (N, *self.R.shape[-2:]))
        q = np.broadcast_to(self.q, (N, self.q.shape[-1]))
        r = np.broadcast_to(self.r, (N, self.r.shape[-1]))
        x, xN = xs[:-1], xs[-1]
        return float(0.5 * np.einsum("ki,kij,kj->", x, Q, x) + np.einsum("ki,ki->", q, x)
                     + 0.5 * np.einsum("ki,kij,kj->", us, R, us) + np.einsum("ki,ki->", r, us)
                     + 0.5 * xN @ self.QN @ xN + self.qN @ xN + self.const)


def reaching_cost(goal, dt=0.01, terminal_weight=1.0, effort_weight=1.0, m=None):
    """Eq. (6.17) discretised: ``J = w_T |x_N - g|^2 + w_u dt sum_k |u_k|^2``.

    ``m`` (number of controls) defaults to the dimension of ``goal`` (x' = u).
    """
    g = np.asarray(goal, dtype=float)
    if g.ndim != 1 or not np.all(np.isfinite(g)):
        raise ValueError(f"goal must be a finite vector, got {goal!r}")
    if not (dt > 0 and terminal_weight >= 0 and effort_weight > 0):
        raise ValueError("dt and effort_weight must be positive and terminal_weight non-negative, "
                         f"got dt={dt}, effort_weight={effort_weight}, terminal_weight={terminal_weight}")
    n = g.shape[0]
    m = n if m is None else m
    return QuadraticCost(Q=np.zeros((n, n)), q=np.zeros(n), R=2 * effort_weight * dt * np.eye(m), r=np.zeros(m),
                         QN=2 * terminal_weight * np.eye(n), qN=-2 * terminal_weight * g,
                         const=terminal_weight * g @ g)


def legible_cost(J1, J0, alpha):
    """The legibility objective ``(1 + alpha) J1 - J0`` (eqs. (6.13), (6.15))."""
    if not np.isfinite(alpha):
        raise ValueError(f"alpha must be finite, got {alpha!r}")
    return (1.0 + alpha) * J1 - J0


def solve(dynamics, cost, x0, N):
    """Exact minimiser of ``cost`` under ``dynamics`` from ``x0`` over ``N`` steps (an LQSolution).

    Raises ValueError if the problem is unbounded (e.g. ``alpha <= 0`` for x' = u).
    """
    dyn = dynamics.stages(0, N)
    c = cost.stages(0, N)
    return solve_lq(dyn.A, dyn.B, c.Q, c.R, x0, N, q=c.q, r=c.r, QN=c.QN, qN=c.qN)


def legible_trajectory(dynamics, J1, J0, x0, N, alpha):
    """Minimiser of ``(1 + alpha) J1 - J0`` (eq. (6.15)); an LQSolution."""
    return solve(dynamics, legible_cost(J1, J0, alpha), x0, N)


def linear_alpha_schedule(alpha_start, alpha_end):
    """An increasing ``alpha(s)`` for eq. (6.16), ``s = t / T`` in [0, 1]:
    ``alpha(s) = alpha_start + (alpha_end - alpha_start) s``.

    Low ``alpha`` early puts the weight on being informative, high ``alpha`` late
    on the task (section 6.5); ``0 < alpha_start <= alpha_end`` is required.
    """
    if not (0 < alpha_start <= alpha_end and np.isfinite(alpha_end)):
        raise ValueError(f"need 0 < alpha_start <= alpha_end < inf, got {alpha_start!r}, {alpha_end!r}")
    return lambda s: alpha_start + (alpha_end - alpha_start) * s


def receding_horizon(dynamics, J1, J0, x0, N, alpha_of_s, every=1):
    """Anticipative legible control by receding horizon (eq. (6.16)).

    Replans at steps ``t_i = 0, every, 2 every, ...`` on the remaining horizon
    ``[t_i, N)`` with ``alpha_i = alpha_of_s(t_i / N)`` and follows each plan until the
    next replanning. The replans' backward Riccati passes share the dynamics and
    differ only in ``alpha``, so they run together in one batched sweep
    (:func:`mutual.lqr.riccati_backward`); the closed loop then applies plan ``i``'s
    feedback on its own steps, which reproduces its open-loop controls exactly.
    Returns ``(xs, us, alphas)`` with ``alphas[k]`` the weight in force at step ``k``.
    """
    if not isinstance(every, (int, np.integer)) or every < 1:
        raise ValueError(f"every must be a positive integer, got {every!r}")
    if not isinstance(N, (int, np.integer)) or N < 1:
        raise ValueError(f"N must be a positive integer, got {N!r}")
    starts = np.arange(0, N, every)
    alphas = np.array([float(alpha_of_s(t / N)) for t in starts])
    if not np.all(np.isfinite(alphas)):
        raise ValueError(f"alpha_of_s returned non-finite weights {alphas.tolist()}")
    dyn, c1, c0 = dynamics.stages(0, N), J1.stages(0, N), J0.stages(0, N)
    n, m = dyn.n, dyn.m
    w = (1.0 + alphas)[:, None, None]

    def mix(f, shape):          # per replan: (1 + alpha_i) J1 - J0, field f
        one = np.broadcast_to(getattr(c1, f), shape)
        zero = np.broadcast_to(getattr(c0, f), shape)
        return w.reshape(-1, *([1] * len(shape))) * one - zero

    A, B = np.broadcast_to(dyn.A, (N, n, n)), np.broadcast_to(dyn.B, (N, n, m))
    K, k, _, _ = riccati_backward(A, B, mix("Q", (N, n, n)), mix("R", (N, m, m)), mix("q", (N, n)),
                                  mix("r", (N, m)), mix("QN", (n, n)), mix("qN", (n,)), starts=starts)
    plan = np.arange(N) // every            # which replan is in force at each step
    Ks, ks = K[plan, np.arange(N)], k[plan, np.arange(N)]
    xs = np.empty((N + 1, n))
    us = np.empty((N, m))
    x = xs[0] = np.asarray(x0, float)
    for t in range(N):
        u = us[t] = Ks[t] @ x + ks[t]
        x = xs[t + 1] = A[t] @ x + B[t] @ u
    return xs, us, alphas[plan]


# ---- the Boltzmann observer in closed form --------------------------------------------------

def lifted_dynamics(dynamics, x0, N):
    """``x_k = Phi_k x0 + G_k u`` for the stacked controls ``u`` (N m,): returns ``(Phi x0, G)``
    with shapes (N+1, n) and (N+1, n, N m)."""
    dyn = dynamics.stages(0, N)
    n, m = dyn.n, dyn.m
    A = np.broadcast_to(dyn.A, (N, n, n))
    B = np.broadcast_to(dyn.B, (N, n, m))
    free = np.empty((N + 1, n))
    G = np.zeros((N + 1, n, N * m))
    free[0] = x0
    for k in range(N):
        free[k + 1] = A[k] @ free[k]
        G[k + 1] = A[k] @ G[k]
        G[k + 1, :, k * m:(k + 1) * m] += B[k]
    return free, G


def lifted_cost(dynamics, cost, x0, N):
    """``J(u) = 1/2 u'H u + h'u + c`` over the stacked controls; returns ``(H, h, c)``."""
    free, G = lifted_dynamics(dynamics, x0, N)
    c = cost.stages(0, N)
    n, m = c.QN.shape[0], c.R.shape[-1]
    Q = np.broadcast_to(c.Q, (N, n, n))
    q = np.broadcast_to(c.q, (N, n))
    R = np.broadcast_to(c.R, (N, m, m))
    r = np.broadcast_to(c.r, (N, m))
    Gs, Gn, fs, fN = G[:N], G[N], free[:N], free[N]
    H = np.einsum("kia,kij,kjb->ab", Gs, Q, Gs) + Gn.T @ c.QN @ Gn
    idx = np.arange(N)
    Hu = H.reshape(N, m, N, m)
    Hu[idx, :, idx, :] += R
    h = (np.einsum("kia,ki->a", Gs, np.einsum("kij,kj->ki", Q, fs) + q) + Gn.T @ (c.QN @ fN + c.qN)
         + r.reshape(-1))
    const = (0.5 * np.einsum("ki,kij,kj->", fs, Q, fs) + np.einsum("ki,ki->", q, fs)
             + 0.5 * fN @ c.QN @ fN + c.qN @ fN + c.const)
    return 0.5 * (H + H.T), h, float(const)


def _gaussian(H, h, c, name):
    """Mean, Cholesky factor of the precision and log Z of ``exp(-(1/2 u'Hu + h'u + c))``."""
    try:
        L = np.linalg.cholesky(H)
    except np.linalg.LinAlgError:
        raise ValueError(f"{name}: exp(-J) is not normalisable (its control Hessian is not positive "
                         "definite), so P(u | H) of eq. (6.8) is undefined") from None
    mean = -np.linalg.solve(H, h)
    d = h.shape[0]
    log_z = -c - 0.5 * h @ mean + 0.5 * d * np.log(2 * np.pi) - np.log(np.diag(L)).sum()
    return mean, L, log_z


def log_boltzmann(dynamics, cost, x0, us):
    """``log P(u | H) = -J(u) - log Z`` (eqs. (6.8)-(6.9)); Gaussian in the stacked controls."""
    us = np.asarray(us, float)
    N = us.shape[0]
    H, h, c = lifted_cost(dynamics, cost, x0, N)
    _, _, log_z = _gaussian(H, h, c, "cost")
    u = us.reshape(-1)
    J = 0.5 * u @ H @ u + h @ u + c
    return float(-J - log_z)


def log_likelihood_ratio(dynamics, J0, J1, x0, us):
    """``log Lambda(u) = log P(u|H0) - log P(u|H1)`` (eq. (6.7)) with the closed-form partition
    functions. Negative values are evidence for H1 over H0 (nats)."""
    return log_boltzmann(dynamics, J0, x0, us) - log_boltzmann(dynamics, J1, x0, us)


def likelihood_ratio_minimiser(dynamics, J0, J1, x0, N, alpha=0.0):
    """Minimiser of ``log Lambda(u) + alpha J1(u)`` from the two Gaussians' means and precisions
    (not through the stage costs): solves ``((1+alpha) P1 - P0) u = (1+alpha) P1 mu1 - P0 mu0``.

    By Theorem 6.4.2 and eq. (6.15) this equals the minimiser of ``(1 + alpha) J1 - J0``.
    Returns the controls (N, m); raises ValueError if the objective is unbounded.
    """
    H0, h0, c0 = lifted_cost(dynamics, J0, x0, N)
    H1, h1, c1 = lifted_cost(dynamics, J1, x0, N)
    mu0, _, _ = _gaussian(H0, h0, c0, "J0")
    mu1, _, _ = _gaussian(H1, h1, c1, "J1")
    P = (1 + alpha) * H1 - H0
    P = 0.5 * (P + P.T)
    if np.linalg.eigvalsh(P)[0] <= 1e-9 * np.abs(H1).max():
        raise ValueError("log Lambda + alpha J1 has no finite minimiser: (1+alpha) P1 - P0 is not "
                         "positive definite")
    u = np.linalg.solve(P, (1 + alpha) * H1 @ mu1 - H0 @ mu0)
    return u.reshape(N, -1)


# ---- several distractors: the QP of section 6.5 -----------------------------------------------

def multi_distractor_qp(dynamics, J1, distractors, x0, N, etas, solver="CLARABEL", tol=1e-9):
    """Solve ``min J1 s.t. J1 - J0_i <= eta_i`` for every distractor ``J0_i`` (section 6.5) in cvxpy.

    Each constraint is affine in ``u`` when the quadratic parts of ``J1`` and ``J0_i``
    cancel (x' = u with eq. (6.17)) and a convex quadratic when ``H1 - H0_i`` is
    positive semidefinite; otherwise the problem is not convex and a ValueError is
    raised. Returns ``(xs, us, duals)``; ``duals[i]`` is the multiplier of constraint i,
    so the solution minimises ``(1 + sum duals) J1 - sum duals_i J0_i`` (the Lagrangian).
    """
    if not len(distractors):
        raise ValueError("distractors must list at least one hypothesis cost")
    try:
        etas = np.broadcast_to(np.asarray(etas, float), (len(distractors),))
    except ValueError:
        raise ValueError(f"etas must be a number or one per distractor ({len(distractors)}), got {etas!r}") from None
    if not np.all(np.isfinite(etas)):
        raise ValueError(f"etas must be finite, got {etas.tolist()}")
    H1, h1, c1 = lifted_cost(dynamics, J1, x0, N)
    u = cp.Variable(H1.shape[0])
    cons = []
    for i, J0 in enumerate(distractors):
        H0, h0, c0 = lifted_cost(dynamics, J0, x0, N)
        D = H1 - H0
        affine = (h1 - h0) @ u + (c1 - c0)
        if np.abs(D).max() <= tol * max(1.0, np.abs(H1).max()):
            cons.append(affine <= etas[i])
        elif np.linalg.eigvalsh(D)[0] >= -tol * np.abs(D).max():
            cons.append(0.5 * cp.quad_form(u, cp.psd_wrap(D)) + affine <= etas[i])
        else:
            raise ValueError(f"distractors[{i}]: J1 - J0 has an indefinite quadratic part, so the "
                             "constraint J1 - J0 <= eta is not convex")
    prob = cp.Problem(cp.Minimize(0.5 * cp.quad_form(u, cp.psd_wrap(H1)) + h1 @ u), cons)
    prob.solve(solver=solver)
    if prob.status not in ("optimal", "optimal_inaccurate"):
        raise ValueError(f"the multi-distractor QP is {prob.status} for etas={etas.tolist()}")
    us = u.value.reshape(N, -1)
    free, G = lifted_dynamics(dynamics, x0, N)
    xs = free + G @ u.value
    return xs, us, np.array([c.dual_value for c in cons], dtype=float).reshape(-1)


def receding_horizon_qp(dynamics, J1, distractors, x0, N, eta_of_s, every=10, solver="CLARABEL"):
    """Anticipative multi-distractor control: replan :func:`multi_distractor_qp` every ``every``
    steps on the remaining horizon with ``eta = eta_of_s(t_i / N)`` (an increasing, i.e.
    loosening, schedule plays the role of the increasing alpha of eq. (6.16)).
    Returns ``(xs, us)``."""
    if not isinstance(every, (int, np.integer)) or every < 1:
        raise ValueError(f"every must be a positive integer, got {every!r}")
    xs, us = [np.asarray(x0, float)], []
    for start in range(0, N, every):
        rest = N - start
        plan_x, plan_u, _ = multi_distractor_qp(
            dynamics.stages(start, rest), J1.stages(start, rest), [J.stages(start, rest) for J in distractors],
            xs[-1], rest, eta_of_s(start / N), solver=solver)
        steps = min(every, rest)
        us.extend(plan_u[:steps])
        xs.extend(plan_x[1:steps + 1])
    return np.array(xs), np.array(us)


# ---- helpers for the chapter's experiments ---------------------------------------------------

def batch_costs(dynamics, cost, x0, us):
    """``J(u)`` for a batch of control sequences ``us`` (B, N, m), through the lifted form."""
    us = np.asarray(us, float)
    H, h, c = lifted_cost(dynamics, cost, x0, us.shape[1])
    U = us.reshape(len(us), -1)
    return 0.5 * np.einsum("bi,ij,bj->b", U, H, U) + U @ h + c


def sample_boltzmann(dynamics, cost, x0, N, size, rng):
    """Draw ``size`` control sequences (size, N, m) from ``P(u | H) = exp(-J(u)) / Z`` (eq. (6.8))."""
    H, h, c = lifted_cost(dynamics, cost, x0, N)
    mean, L, _ = _gaussian(H, h, c, "cost")
    z = rng.standard_normal((size, len(mean)))
    # u = mean + L^{-T} z has covariance (L L')^{-1} = H^{-1}
    u = mean + np.linalg.solve(L.T, z.T).T
    return u.reshape(size, N, -1)


def random_lq_hypotheses(rng, n=2, m=2, N=10):
    """Random dynamics and hypotheses ``J0``, ``J1`` with ``J1 - J0`` strictly convex (so that
    ``Lambda`` has a unique minimiser); returns ``(dynamics, J0, J1, x0)``."""
    def cost(effort):
        L, Lr, LN = rng.normal(size=(N, n, n)), rng.normal(size=(N, m, m)), rng.normal(size=(n, n))
        return QuadraticCost(Q=L @ L.transpose(0, 2, 1) / n, q=rng.normal(size=(N, n)),
                             R=Lr @ Lr.transpose(0, 2, 1) / m + effort * np.eye(m), r=rng.normal(size=(N, m)),
                             QN=LN @ LN.T, qN=rng.normal(size=n), const=rng.normal())
    dyn = LinearDynamics(np.eye(n) + 0.2 * rng.normal(size=(n, n)), rng.normal(size=(n, m)))
    J0 = cost(1.0)
    return dyn, J0, J0 + cost(0.5), rng.normal(size=n)


def time_to_reach(xs, level, dt, axis=0):
    """First time at which coordinate ``axis`` of the trajectory ``xs`` reaches ``level``
    (linear interpolation between knots); ``inf`` if it never does."""
    x = np.asarray(xs, float)[:, axis] - level
    side = np.sign(x[0])
    if side == 0:
        return 0.0
    crossed = np.nonzero(side * x <= 0)[0]
    if crossed.size == 0:
        return np.inf
    k = crossed[0]
    return float((k - 1 + x[k - 1] / (x[k - 1] - x[k])) * dt)


def lateral_share(xs, start, stop, axis=0):
    """Fraction of the path length between knots ``start`` and ``stop`` that is lateral
    (along coordinate ``axis``): 1 for sideways motion, 0 for motion straight ahead."""
    steps = np.diff(np.asarray(xs, float), axis=0)[start:stop]
    return float(np.abs(steps[:, axis]).sum() / np.linalg.norm(steps, axis=1).sum())
