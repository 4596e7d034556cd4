"""Finite-horizon linear-quadratic optimal control by the Riccati recursion.

The problem (discrete time, horizon ``N``, the LQ case of eqs. (6.1), (6.3)-(6.4))::

    min_u  sum_{k<N} [ 1/2 x_k'Q_k x_k + q_k'x_k + 1/2 u_k'R_k u_k + r_k'u_k + x_k'M_k u_k ]
           + 1/2 x_N'Q_N x_N + q_N'x_N
    s.t.   x_{k+1} = A_k x_k + B_k u_k + c_k,   x_0 given.

Every stage array may be given once (time-invariant, e.g. ``A`` of shape (n, n))
or per stage (time-varying, ``A`` of shape (N, n, n)). ``Q_k`` need not be
positive semidefinite (legible objectives subtract costs, eq. (6.15)): the
problem is bounded below with a unique minimiser exactly when every
``Q_uu,k = R_k + B_k'V_{k+1}B_k`` of the backward pass is positive definite,
and :func:`solve_lq` raises a ValueError naming a stage where it is not.
:func:`riccati_backward` runs the backward passes of many problems that share the
dynamics at once (receding-horizon replanning, eq. (6.16)).

Weight matrices must be symmetric. A quadratic form ``u'Ru`` sees only the symmetric part
of ``R``, so a non-symmetric ``R`` (say ``[[1, 5], [-5, 1]]``) describes the same cost as
``(R + R')/2``, but the Riccati formulas assume symmetry and would silently solve another
problem. We refuse (ValueError naming the argument) rather than symmetrise: an asymmetric
weight is almost always a construction error (a transposed block), and a caller who means
the quadratic form can pass ``(R + R')/2``. Asymmetry at rounding level (relative 1e-10)
is removed silently.

``backend="numpy"`` (default) is the reference recursion; ``backend="jax"`` the compiled
one of :mod:`mutual.motion.legible.lqr_compiled` (same answer to rounding, tens of times faster
for long horizons after a compile of about a second per size).
"""

from dataclasses import dataclass

import numpy as np

from ..riccati import LQStage, riccati_step


@dataclass(frozen=True)
class LQSolution:
    """Optimal trajectory and policy of a finite-horizon LQ problem.

    ``xs`` (N+1, n) states, ``us`` (N, m) controls, ``K`` (N, m, n) and ``k``
    (N, m) the affine feedback policy ``u_k = K_k x_k + k_k``, ``V`` (N+1, n, n)
    and ``v`` (N+1, n) the cost-to-go ``1/2 x'V_k x + v_k'x + const``, and
    ``cost`` the optimal objective value (no constant terms are included).
    """

    xs: np.ndarray
    us: np.ndarray
    K: np.ndarray
    k: np.ndarray
    V: np.ndarray
    v: np.ndarray
    cost: float

    def __repr__(self):
        N, m = self.us.shape
        n = self.xs.shape[1]
        ends = np.array2string(self.xs[-1], precision=4, separator=", ")
        return f"LQSolution(N={N}, n={n}, m={m}, cost={self.cost:.6g}, x_N={ends})"


def _stage(name, value, N, shape, square=False):
    """Broadcast a stage array to (N, *shape) after checking it is finite (and symmetric when
    ``square``), or raise naming the argument. A time-invariant array is checked once and returned
    as a broadcast view (stride 0), which the compiled backend recognises."""
    a = np.asarray(value, dtype=float)
    if a.shape not in (shape, (N, *shape)):
        raise ValueError(f"{name} has shape {a.shape}; expected {shape} (time-invariant) or {(N, *shape)} (per stage)")
    a = _is_finite(name, a)
    if square:
        a = symmetric(name, a)
    return np.broadcast_to(a, (N, *shape)) if a.shape == shape else a


def _terminal(name, value, shape):
    a = np.asarray(value, dtype=float)
    if a.shape != shape:
        raise ValueError(f"{name} has shape {a.shape}; expected {shape}")
    return a


def _is_finite(name, a):
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains non-finite values")
    return a


SYMMETRY_RTOL = 1e-10


def symmetric(name, a):
    """``a`` (..., k, k) made exactly symmetric, or a ValueError naming ``name`` if it is not
    symmetric up to rounding (see the module docstring for why we refuse)."""
    a = np.asarray(a, float)
    gap = np.abs(a - np.swapaxes(a, -1, -2)).max(initial=0.0)
    if gap > SYMMETRY_RTOL * max(1.0, np.abs(a).max(initial=0.0)):
        raise ValueError(f"{name} is not symmetric (max |{name} - {name}'| = {gap:.3g}); the cost uses only its "
                         f"symmetric part, so pass ({name} + {name}')/2 if that is the weight you mean")
    return 0.5 * (a + np.swapaxes(a, -1, -2))


_UNBOUNDED = ("the cost has no unique finite minimiser (for a legible objective (1+alpha) J1 - J0 "
              "with x' = u this means alpha <= 0)")


def riccati_backward(A, B, Q, R, q, r, QN, qN, M=None, c=None, starts=None):
    """Backward Riccati passes of ``P`` LQ problems sharing the dynamics, all at once.

    ``A`` (N, n, n), ``B`` (N, n, m), ``c`` (N, n) are shared; the costs carry a
    leading problem axis: ``Q`` (P, N, n, n), ``R`` (P, N, m, m), ``q`` (P, N, n),
    ``r`` (P, N, m), ``M`` (P, N, n, m), ``QN`` (P, n, n), ``qN`` (P, n). Problem ``p``
    starts at stage ``starts[p]`` (non-decreasing; default 0): its earlier stages are
    skipped, as when replanning on a shrinking horizon (eq. (6.16)). Returns the gains
    ``K`` (P, N, m, n), ``k`` (P, N, m) and cost-to-go ``V`` (P, N+1, n, n), ``v`` (P, N+1, n)
    (zero before each problem's start). Raises ValueError if a problem is unbounded.
    """
    P, N = Q.shape[:2]
    n, m = B.shape[1:]
    starts = np.zeros(P, dtype=int) if starts is None else np.asarray(starts)
    if starts.shape != (P,) or np.any(np.diff(starts) < 0) or starts.min() < 0 or starts.max() >= N:
        raise ValueError(f"starts must be {P} non-decreasing stage indices in [0, {N}), got {starts!r}")
    M = np.zeros((P, N, n, m)) if M is None else M
    c = np.zeros((N, n)) if c is None else c
    F = np.concatenate([A, B], axis=2)                               # x' = A x + B u + c = F (x, u) + c
    H = np.empty((P, N, n + m, n + m))                               # the cost 1/2 z'H z + g'z in z = (x, u)
    H[..., :n, :n], H[..., :n, n:], H[..., n:, :n], H[..., n:, n:] = Q, M, M.transpose(0, 1, 3, 2), R
    g = np.concatenate([np.broadcast_to(q, (P, N, n)), np.broadcast_to(r, (P, N, m))], axis=2)
    active = np.searchsorted(starts, np.arange(N), side="right")   # problems already started at stage k
    K, kff = np.zeros((P, N, m, n)), np.zeros((P, N, m))
    V, v = np.zeros((P, N + 1, n, n)), np.zeros((P, N + 1, n))
    Quu = np.tile(np.eye(m), (P, N, 1, 1))
    V[:, N] = 0.5 * (QN + QN.transpose(0, 2, 1))
    v[:, N] = qN
    with np.errstate(invalid="ignore", over="ignore"):   # an unbounded problem's NaN: reported below
        for t in range(N - 1, -1, -1):
            a = active[t]
            stage = LQStage(F=F[t], H=H[:a, t], g=g[:a, t], c=c[t])
            step = riccati_step(V[:a, t + 1], v[:a, t + 1], stage, factor=False)   # tested below
            Quu[:a, t], K[:a, t], kff[:a, t] = step.Q_uu, step.K, step.k
            V[:a, t], v[:a, t] = step.V, step.v
    _check_convex(Quu, R, B, V, started=np.arange(N) >= starts[:, None])
    return K, kff, V, v


def _check_convex(Quu, R, B, V, started, rtol=1e-9):
    """Raise if the control Hessian ``R + B'V B`` of some started stage is not positive definite."""
    sym = 0.5 * (Quu + Quu.swapaxes(-1, -2))
    finite = np.all(np.isfinite(sym), axis=(-2, -1))
    eig = np.full(sym.shape[:-2], np.nan)
    eig[finite] = np.linalg.eigvalsh(sym[finite])[:, 0]
    BVB = np.einsum("kia,pkij,kjb->pkab", B, V[:, 1:], B)
    scale = np.abs(R).max(axis=(-2, -1)) + np.abs(BVB).max(axis=(-2, -1))
    bad = np.argwhere(~(eig > rtol * scale) & started)
    if len(bad):
        p, t = bad[np.argmax(bad[:, 1])]
        raise ValueError(
            f"unbounded LQ problem: the control Hessian R + B'VB at stage {t} has eigenvalue "
            f"{eig[p, t]:.3g} (not positive definite); " + _UNBOUNDED)


def lq_cost(xs, us, Q, R, q=None, r=None, QN=None, qN=None, M=None):
    """Objective value of a given trajectory ``(xs, us)`` under the LQ cost above."""
    xs, us = np.asarray(xs, float), np.asarray(us, float)
    N, m = us.shape
    n = xs.shape[1]
    Q, R = _stage("Q", Q, N, (n, n)), _stage("R", R, N, (m, m))
    q = _stage("q", np.zeros(n) if q is None else q, N, (n,))
    r = _stage("r", np.zeros(m) if r is None else r, N, (m,))
    M = _stage("M", np.zeros((n, m)) if M is None else M, N, (n, m))
    QN = _terminal("QN", np.zeros((n, n)) if QN is None else QN, (n, n))
    qN = _terminal("qN", np.zeros(n) if qN is None else qN, (n,))
    x, xN = xs[:-1], xs[-1]
    running = (0.5 * np.einsum("ki,kij,kj->", x, Q, x) + np.einsum("ki,ki->", q, x)
               + 0.5 * np.einsum("ki,kij,kj->", us, R, us) + np.einsum("ki,ki->", r, us)
               + np.einsum("ki,kij,kj->", x, M, us))
    return float(running + 0.5 * xN @ QN @ xN + qN @ xN)


def solve_lq(A, B, Q, R, x0, N, q=None, r=None, QN=None, qN=None, M=None, c=None, backend="numpy"):
    """Solve the finite-horizon LQ problem above exactly (backward Riccati pass,
    forward rollout); return an :class:`LQSolution`.

    ``A`` (n, n) or (N, n, n); ``B`` (n, m) or (N, n, m); ``Q`` (n, n) or (N, n, n);
    ``R`` (m, m) or (N, m, m); ``q``, ``r``, ``M``, ``c`` likewise (default zero);
    ``QN`` (n, n) and ``qN`` (n,) the terminal cost (default zero). ``Q``, ``R`` and ``QN``
    must be symmetric. ``backend``: ``"numpy"`` (reference) or ``"jax"`` (compiled).
    Raises ValueError when the problem is unbounded below or has no unique
    minimiser: with ``"numpy"`` when some ``Q_uu,k`` has an eigenvalue <= 1e-9 times its
    scale, with ``"jax"`` when a Cholesky pivot of ``Q_uu,k`` is (the pivots bound the smallest
    eigenvalue from above, so both refuse every singular or indefinite ``Q_uu,k``).
    """
    if backend not in ("numpy", "jax"):
        raise ValueError(f"backend must be 'numpy' or 'jax', got {backend!r}")
    if not isinstance(N, (int, np.integer)) or N < 1:
        raise ValueError(f"N must be a positive integer, got {N!r}")
    x0 = _is_finite("x0", np.asarray(x0, dtype=float))
    if x0.ndim != 1:
        raise ValueError(f"x0 must be a vector, got shape {x0.shape}")
    n = x0.shape[0]
    B_arr = np.asarray(B, dtype=float)
    if B_arr.ndim not in (2, 3) or B_arr.shape[-2] != n:
        raise ValueError(f"B has shape {B_arr.shape}; expected ({n}, m) or ({N}, {n}, m)")
    m = B_arr.shape[-1]
    A = _stage("A", A, N, (n, n))
    B = _stage("B", B_arr, N, (n, m))
    Q = _stage("Q", Q, N, (n, n), square=True)
    R = _stage("R", R, N, (m, m), square=True)
    q = _stage("q", np.zeros(n) if q is None else q, N, (n,))
    r = _stage("r", np.zeros(m) if r is None else r, N, (m,))
    M = _stage("M", np.zeros((n, m)) if M is None else M, N, (n, m))
    c = _stage("c", np.zeros(n) if c is None else c, N, (n,))
    QN = symmetric("QN", _is_finite("QN", _terminal("QN", np.zeros((n, n)) if QN is None else QN, (n, n))))
    qN = _is_finite("qN", _terminal("qN", np.zeros(n) if qN is None else qN, (n,)))

    if backend == "jax":
        from .lqr_compiled import riccati_compiled
        stages = dict(A=A, B=B, Q=Q, R=R, q=q, r=r, M=M, c=c)
        xs, us, K, kff, V, v, pivots, scales, cost = riccati_compiled(stages, QN, qN, x0, N)
        bad = np.nonzero(~(pivots > 1e-9 * scales))[0]
        if len(bad):
            t = bad.max()
            pivot = f"Cholesky pivot {pivots[t]:.3g}" if np.isfinite(pivots[t]) else "a negative Cholesky pivot"
            raise ValueError(f"unbounded LQ problem: the control Hessian R + B'VB at stage {t} has {pivot} "
                             "(not positive definite); " + _UNBOUNDED)
        return LQSolution(xs=xs, us=us, K=K, k=kff, V=V, v=v, cost=cost)

    K, kff, V, v = riccati_backward(A, B, Q[None], R[None], q[None], r[None], QN[None], qN[None], M=M[None], c=c)
    K, kff, V, v = K[0], kff[0], V[0], v[0]
    xs = np.empty((N + 1, n))
    us = np.empty((N, m))
    x = xs[0] = x0
    for t in range(N):
        u = us[t] = K[t] @ x + kff[t]
        x = xs[t + 1] = A[t] @ x + B[t] @ u + c[t]
    cost = lq_cost(xs, us, Q, R, q, r, QN, qN, M)
    return LQSolution(xs=xs, us=us, K=K, k=kff, V=V, v=v, cost=cost)
