"""Linear-quadratic hypotheses for chapter 6: linear dynamics ``x_{k+1} = A x_k + B u_k`` and quadratic
costs (eq. (6.3)), with the reaching cost of eq. (6.17) and the exact minimiser by the Riccati
recursion (:func:`mutual.motion.legible.lqr.solve_lq`).

Costs use the convention of :mod:`.lqr`: stage cost ``1/2 x'Qx + q'x + 1/2 u'Ru + r'u``, terminal
``1/2 x'Q_N x + q_N'x``, plus a constant, so that costs add and scale (``1.5 * J1 - J0``) exactly as
hypotheses do in eq. (6.15). With quadratic costs and linear dynamics ``P(u | H_i)`` is Gaussian
in the stacked controls, so ``Z_i`` and ``Lambda`` have closed forms (:mod:`mutual.motion.observer`).
"""

from dataclasses import dataclass

import numpy as np

from .lqr import solve_lq, symmetric


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
        if self.A.ndim == 2 and self.B.ndim == 2:
            return self                                  # time-invariant and immutable
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
        """The cost of stages ``start .. start + N - 1`` plus the terminal cost (for replanning); the cost
        itself when no field varies over the stages (it is immutable)."""
        if not any(self._per_stage(f) for f in _STAGE_FIELDS):
            return self
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


def solve(dynamics, cost, x0, N, backend="numpy"):
    """Exact minimiser of ``cost`` under ``dynamics`` from ``x0`` over ``N`` steps (an LQSolution).

    ``backend``: ``"numpy"`` or ``"jax"`` (compiled, :mod:`.lqr_compiled`).
    Raises ValueError if the problem is unbounded (e.g. ``alpha <= 0`` for x' = u).
    """
    check_lq_problem(dynamics, cost, N)
    dyn = dynamics.stages(0, N)
    c = cost.stages(0, N)
    return solve_lq(dyn.A, dyn.B, c.Q, c.R, x0, N, q=c.q, r=c.r, QN=c.QN, qN=c.qN, backend=backend)


def check_lq_problem(dynamics, cost, N):
    """Refuse dynamics, a cost or a horizon that do not make one LQ problem, naming the argument."""
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
