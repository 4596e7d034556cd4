"""Legible motion as hypothesis testing for linear-quadratic hypotheses (chapter 6).

An observer decides between hypotheses ``H_i``, each an optimal-control problem
with cost ``J_i`` (eq. (6.3)); it models the robot's controls as Boltzmann
distributed, ``P(u | H_i) = exp(-J_i(u)) / Z_i`` (eq. (6.8)). By Theorem 6.4.2
the likelihood ratio ``Lambda = P(u|H0) / P(u|H1)`` (eq. (6.7)) has the same
minimisers as ``J1 - J0`` (eq. (6.13)); weighting the task, ``(1 + alpha) J1 - J0``
(eq. (6.15)). For linear dynamics and quadratic costs this is one LQ problem,
solved exactly by :func:`mutual.motion.lqr.solve_lq`.

Costs use the convention of :mod:`mutual.motion.lqr`: stage cost ``1/2 x'Qx + q'x +
1/2 u'Ru + r'u``, terminal ``1/2 x'Q_N x + q_N'x``, plus a constant, so that
costs add and scale (``1.5 * J1 - J0``) exactly as hypotheses do in eq. (6.15).
With quadratic costs and linear dynamics ``P(u | H_i)`` is Gaussian in the
stacked controls, so ``Z_i`` and ``Lambda`` have closed forms (:mod:`.observer`); several
distractors at once are the QP of :mod:`.qp`.
"""

from dataclasses import dataclass

import numpy as np

from .lqr import riccati_backward, solve_lq, symmetric


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
        if A.ndim == 3 and B.ndim == 3 and len(A) != len(B):
            raise ValueError(f"A and B must have the same number of stages, got {len(A)} and {len(B)}")
        for name, a in (("A", A), ("B", B)):
            if not np.all(np.isfinite(a)):
                raise ValueError(f"dynamics {name} contains non-finite values")
        object.__setattr__(self, "A", A)
        object.__setattr__(self, "B", B)

    def __repr__(self):
        stages = [len(a) for a in (self.A, self.B) if a.ndim == 3]
        kind = f"time-varying, {stages[0]} stages" if stages else "time-invariant"
        return f"LinearDynamics(n={self.n}, m={self.m}, {kind})"

    @property
    def n(self):
        return self.A.shape[-1]

    @property
    def m(self):
        return self.B.shape[-1]

    def stages(self, start, N):
        """The dynamics of stages ``start .. start + N - 1`` (for replanning)."""
        for a in (self.A, self.B):
            if a.ndim == 3 and len(a) < start + N:
                raise ValueError(f"the dynamics have {len(a)} stages; stages {start}..{start + N - 1} were asked for")
        A = self.A[start:start + N] if self.A.ndim == 3 else self.A
        B = self.B[start:start + N] if self.B.ndim == 3 else self.B
        return LinearDynamics(A, B)


def _check_dim_dt(dim, dt):
    if not (isinstance(dt, (int, float, np.integer, np.floating)) and np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive finite number, got {dt!r}")
    if not isinstance(dim, (int, np.integer)) or isinstance(dim, bool) or dim < 1:
        raise ValueError(f"dim must be a positive integer, got {dim!r}")


def single_integrator(dim=2, dt=0.01):
    """Path-planning dynamics ``x' = u`` (eq. (6.5)), Euler-discretised: ``x_{k+1} = x_k + dt u_k``."""
    _check_dim_dt(dim, dt)
    return LinearDynamics(np.eye(dim), dt * np.eye(dim))


def double_integrator(dim=2, dt=0.01):
    """``p'' = u`` in ``dim`` dimensions, exactly discretised with zero-order hold; the state is
    ``(p, v)`` (positions, then velocities), ``n = 2 dim`` states and ``m = dim`` controls."""
    _check_dim_dt(dim, dt)
    I = np.eye(dim)
    A = np.block([[I, dt * I], [np.zeros((dim, dim)), I]])
    B = np.vstack([0.5 * dt ** 2 * I, dt * I])
    return LinearDynamics(A, B)


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
        for f in _FIELDS:
            if not np.all(np.isfinite(getattr(self, f))):
                raise ValueError(f"cost field {f} contains non-finite values")
        for f in ("Q", "R", "QN"):
            object.__setattr__(self, f, symmetric(f"cost field {f}", getattr(self, f)))
        if not np.isfinite(self.const):
            raise ValueError(f"cost const must be finite, got {self.const!r}")
        object.__setattr__(self, "const", float(self.const))

    def __repr__(self):
        n, m = self.QN.shape[0], self.R.shape[-1]
        stages = [len(getattr(self, f)) for f in _STAGE_FIELDS if self._per_stage(f)]
        kind = f"per-stage over {stages[0]} stages" if stages else "time-invariant"
        return f"QuadraticCost(n={n}, m={m}, {kind}, const={self.const:.6g})"

    @classmethod
    def _combined(cls, fields, const):
        """A cost from fields that are sums or finite multiples of valid costs' fields (so finite and
        symmetric already): skips the checks of ``__post_init__``, which the arithmetic would repeat."""
        cost = object.__new__(cls)
        for f, a in zip(_FIELDS, fields):
            object.__setattr__(cost, f, a)
        object.__setattr__(cost, "const", float(const))
        if not (np.isfinite(cost.const) and all(np.all(np.isfinite(a)) for a in fields)):
            raise ValueError("cost arithmetic overflowed to non-finite values")
        return cost

    def __add__(self, other):
        if not isinstance(other, QuadraticCost):
            return NotImplemented
        fields = [getattr(self, f) + getattr(other, f) for f in _FIELDS]
        for f, a in zip(_FIELDS, fields):           # a time-invariant plus a per-stage field is per stage
            if a.ndim != getattr(self, f).ndim or a.ndim != getattr(other, f).ndim:
                return QuadraticCost(*fields, self.const + other.const)
        return QuadraticCost._combined(fields, self.const + other.const)

    def __mul__(self, w):
        if isinstance(w, (str, bytes, bool, QuadraticCost)) or np.ndim(w) != 0:
            return NotImplemented
        try:
            w = float(w)
        except (TypeError, ValueError):
            return NotImplemented
        if not np.isfinite(w):
            raise ValueError(f"a cost can only be scaled by a finite number, got {w!r}")
        return QuadraticCost._combined([w * getattr(self, f) for f in _FIELDS], w * self.const)

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
        n, m = self.QN.shape[0], self.R.shape[-1]
        if us.ndim != 2 or us.shape[1] != m or xs.shape != (len(us) + 1, n):
            raise ValueError(f"xs and us must have shapes (N+1, {n}) and (N, {m}), got {xs.shape} and {us.shape}")
        for name, a in (("xs", xs), ("us", us)):
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{name} contains non-finite values")
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
    if not (np.isfinite([dt, terminal_weight, effort_weight]).all() and dt > 0 and terminal_weight >= 0
            and effort_weight > 0):
        raise ValueError("dt and effort_weight must be positive and terminal_weight non-negative (all finite), "
                         f"got dt={dt}, effort_weight={effort_weight}, terminal_weight={terminal_weight}")
    n = g.shape[0]
    m = n if m is None else m
    if not isinstance(m, (int, np.integer)) or m < 1:
        raise ValueError(f"m (the number of controls) must be a positive integer, got {m!r}")
    return QuadraticCost(Q=np.zeros((n, n)), q=np.zeros(n), R=2 * effort_weight * dt * np.eye(m), r=np.zeros(m),
                         QN=2 * terminal_weight * np.eye(n), qN=-2 * terminal_weight * g,
                         const=terminal_weight * g @ g)


def distractor_mixture(J0, weights=None):
    """``sum_i w_i J0_i`` for a list of distractor costs (default equal weights summing to one);
    a single QuadraticCost is returned as it is. The Lagrangian of the multi-distractor problem
    of section 6.5 weighs the distractors this way (its multipliers are the weights)."""
    if isinstance(J0, QuadraticCost):
        if weights is not None:
            raise ValueError("weights are only for a list of distractors J0")
        return J0
    costs = list(J0)
    if not costs or not all(isinstance(J, QuadraticCost) for J in costs):
        raise ValueError("J0 must be a QuadraticCost or a non-empty list of QuadraticCosts")
    w = np.full(len(costs), 1.0 / len(costs)) if weights is None else np.asarray(weights, float)
    if w.shape != (len(costs),) or not np.all(np.isfinite(w)) or np.any(w < 0) or not w.sum() > 0:
        raise ValueError(f"weights must be {len(costs)} finite non-negative numbers, not all zero, got {weights!r}")
    total = w[0] * costs[0]
    for wi, J in zip(w[1:], costs[1:]):
        total = total + wi * J
    return total


def legible_cost(J1, J0, alpha, weights=None):
    """The legibility objective ``(1 + alpha) J1 - J0`` (eqs. (6.13), (6.15)); ``J0`` may be a list of
    distractors, combined by :func:`distractor_mixture` (``weights``, default equal). ``J1`` and ``J0``
    may be anything that adds and scales (QuadraticCosts, or chapter 7's feature-weight vectors)."""
    if isinstance(alpha, (str, bytes, bool)) or np.ndim(alpha) != 0:
        raise ValueError(f"alpha must be a finite number, got {alpha!r}")
    try:
        finite = bool(np.isfinite(alpha))
    except Exception:           # a traced (JAX) value: checked where it is concrete
        finite = True
    if not finite:
        raise ValueError(f"alpha must be a finite number, got {alpha!r}")
    if isinstance(J0, (list, tuple)):
        J0 = distractor_mixture(J0, weights)
    elif weights is not None:
        raise ValueError("weights are only for a list of distractors J0")
    return (1.0 + alpha) * J1 - J0


def solve(dynamics, cost, x0, N, backend="numpy"):
    """Exact minimiser of ``cost`` under ``dynamics`` from ``x0`` over ``N`` steps (an LQSolution).

    ``backend``: ``"numpy"`` or ``"jax"`` (compiled, :mod:`mutual.motion.lqr_compiled`).
    Raises ValueError if the problem is unbounded (e.g. ``alpha <= 0`` for x' = u).
    """
    _check_problem(dynamics, cost, N)
    dyn = dynamics.stages(0, N)
    c = cost.stages(0, N)
    return solve_lq(dyn.A, dyn.B, c.Q, c.R, x0, N, q=c.q, r=c.r, QN=c.QN, qN=c.qN, backend=backend)


def _check_problem(dynamics, cost, N):
    if not isinstance(dynamics, LinearDynamics):
        raise ValueError(f"dynamics must be a LinearDynamics, got {type(dynamics).__name__}")
    if not isinstance(cost, QuadraticCost):
        raise ValueError(f"cost must be a QuadraticCost, got {type(cost).__name__}")
    if not isinstance(N, (int, np.integer)) or isinstance(N, bool) or N < 1:
        raise ValueError(f"N must be a positive integer, got {N!r}")
    if (cost.QN.shape[0], cost.R.shape[-1]) != (dynamics.n, dynamics.m):
        raise ValueError(f"the cost is for n = {cost.QN.shape[0]} states and m = {cost.R.shape[-1]} controls, "
                         f"the dynamics have n = {dynamics.n}, m = {dynamics.m}")
    for f in _STAGE_FIELDS:
        a = getattr(cost, f)
        if cost._per_stage(f) and len(a) < N:
            raise ValueError(f"cost field {f} has {len(a)} stages; N = {N} were asked for")


def legible_trajectory(dynamics, J1, J0, x0, N, alpha, weights=None, backend="numpy"):
    """Minimiser of ``(1 + alpha) J1 - J0`` (eq. (6.15)); an LQSolution. ``J0`` may be a list of
    distractors (combined with ``weights``, default equal: the Lagrangian form of section 6.5)."""
    return solve(dynamics, legible_cost(J1, J0, alpha, weights), x0, N, backend=backend)


def linear_alpha_schedule(alpha_start, alpha_end):
    """An increasing ``alpha(s)`` for eq. (6.16), ``s = t / T`` in [0, 1]:
    ``alpha(s) = alpha_start + (alpha_end - alpha_start) s``.

    Low ``alpha`` early puts the weight on being informative, high ``alpha`` late
    on the task (section 6.5); ``0 < alpha_start <= alpha_end`` is required.
    """
    if not (0 < alpha_start <= alpha_end and np.isfinite(alpha_end)):
        raise ValueError(f"need 0 < alpha_start <= alpha_end < inf, got {alpha_start!r}, {alpha_end!r}")
    return lambda s: alpha_start + (alpha_end - alpha_start) * s


def geometric_alpha_schedule(alpha_start, alpha_end):
    """An increasing ``alpha(s) = alpha_start (alpha_end / alpha_start)^s`` for eq. (6.16), ``s = t / T``:
    equal ratios of task to communication weight in equal times."""
    if not (0 < alpha_start <= alpha_end and np.isfinite(alpha_end)):
        raise ValueError(f"need 0 < alpha_start <= alpha_end < inf, got {alpha_start!r}, {alpha_end!r}")
    return lambda s: alpha_start * (alpha_end / alpha_start) ** s


def replan_gains(dynamics, J1, J0, N, w1, w0, starts):
    """Feedback gains of the replans ``min w1[p] J1 - w0[p] J0`` on ``[starts[p], N)`` (eq. (6.16)),
    all from one batched backward sweep (:func:`mutual.motion.lqr.riccati_backward`): returns
    ``K`` (P, N, m, n) and ``k`` (P, N, m); replan ``p``'s control at step ``t >= starts[p]`` is
    ``K[p, t] x_t + k[p, t]``."""
    dyn, c1, c0 = dynamics.stages(0, N), J1.stages(0, N), J0.stages(0, N)
    n, m = dyn.n, dyn.m
    w1, w0 = np.asarray(w1, float), np.asarray(w0, float)

    def mix(f, shape):          # per replan: w1 J1 - w0 J0, field f
        one = np.broadcast_to(getattr(c1, f), shape)
        zero = np.broadcast_to(getattr(c0, f), shape)
        lead = (-1, *([1] * len(shape)))
        return w1.reshape(lead) * one - w0.reshape(lead) * zero

    A, B = np.broadcast_to(dyn.A, (N, n, n)), np.broadcast_to(dyn.B, (N, n, m))
    K, k, _, _ = riccati_backward(A, B, mix("Q", (N, n, n)), mix("R", (N, m, m)), mix("q", (N, n)),
                                  mix("r", (N, m)), mix("QN", (n, n)), mix("qN", (n,)), starts=starts)
    return K, k


def receding_horizon(dynamics, J1, J0, x0, N, alpha_of_s, every=1):
    """Anticipative legible control by receding horizon (eq. (6.16)).

    Replans at steps ``t_i = 0, every, 2 every, ...`` on the remaining horizon
    ``[t_i, N)`` with ``alpha_i = alpha_of_s(t_i / N)`` and follows each plan until the
    next replanning. The replans' backward Riccati passes share the dynamics and
    differ only in ``alpha``, so they run together in one batched sweep
    (:func:`mutual.motion.lqr.riccati_backward`); the closed loop then applies plan ``i``'s
    feedback on its own steps, which reproduces its open-loop controls exactly.
    Returns ``(xs, us, alphas)`` with ``alphas[k]`` the weight in force at step ``k``.
    ``J0`` may be a list of distractors (combined with equal weights, :func:`distractor_mixture`).
    """
    if not isinstance(every, (int, np.integer)) or every < 1:
        raise ValueError(f"every must be a positive integer, got {every!r}")
    if not isinstance(N, (int, np.integer)) or N < 1:
        raise ValueError(f"N must be a positive integer, got {N!r}")
    if not callable(alpha_of_s):
        raise ValueError(f"alpha_of_s must be a function of s = t / N in [0, 1], got {alpha_of_s!r}")
    J0 = distractor_mixture(J0)
    _check_problem(dynamics, J1, N)
    _check_problem(dynamics, J0, N)
    x0 = np.asarray(x0, float)
    if x0.shape != (dynamics.n,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be a finite vector of length {dynamics.n}, got {x0!r}")
    starts = np.arange(0, N, every)
    alphas = np.array([float(alpha_of_s(t / N)) for t in starts])
    if not np.all(np.isfinite(alphas)):
        raise ValueError(f"alpha_of_s returned non-finite weights {alphas.tolist()}")
    K, k = replan_gains(dynamics, J1, J0, N, 1.0 + alphas, np.ones_like(alphas), starts)
    dyn = dynamics.stages(0, N)
    n, m = dyn.n, dyn.m
    A, B = np.broadcast_to(dyn.A, (N, n, n)), np.broadcast_to(dyn.B, (N, n, m))
    plan = np.arange(N) // every            # which replan is in force at each step
    Ks, ks = K[plan, np.arange(N)], k[plan, np.arange(N)]
    xs = np.empty((N + 1, n))
    us = np.empty((N, m))
    x = xs[0] = np.asarray(x0, float)
    for t in range(N):
        u = us[t] = Ks[t] @ x + ks[t]
        x = xs[t + 1] = A[t] @ x + B[t] @ u
    return xs, us, alphas[plan]


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
