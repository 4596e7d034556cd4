"""The Boltzmann observer of eq. (6.8) at any horizon: ``exp(-J(u)) / Z`` factored stage by stage.

For dynamics ``x_{t+1} = A_t x_t + B_t u_t + c_t`` and a quadratic cost, ``P(u | H) = exp(-J(u)) / Z``
is Gaussian in the stacked controls. Its precision (the Hessian of ``J``) is block-banded, and the
Riccati backward pass (:func:`riccati_factor`) is its block LDL' factorisation in reverse stage
order. Integrating ``exp(-J)`` over the controls not yet seen leaves
``exp(-Q_t(x_t, u_t))`` times a constant (an LQ problem's soft value differs from its value by a
state-independent log-determinant), and the state summarises the past, so the observer's
conditional is the maximum-entropy LQR policy::

    u_t | u_0 .. u_{t-1}  ~  N(K_t x_t + k_t, Q_uu,t^-1),      Q_uu,t = R_t + B_t'V_{t+1} B_t = L_t L_t'

(``u = K x + k`` as in :mod:`mutual.motion.legible.lqr`). So ``log P(u) = sum_t log N(u_t; ...)``
needs no partition function, ``log det`` of the precision is ``sum_t log det Q_uu,t``, and every
prefix marginal ``log P(u_{0:t})`` is a running sum: O(N) time and memory where the dense form
needs an (N m)^2 Hessian. A Laplace approximation around a nonlinear optimum is the same object
(:func:`mutual.motion.belief.laplace_gaussian`).

Numerics: with the whitened residual ``r_t = L_t'(u_t - K_t x_t - k_t) = rho_t - e_t`` (``rho``
linear in the controls and the start, ``e_t = L_t' k_t``), a log-likelihood ratio is
``-1/2 sum (r0 - r1).(r0 + r1)`` with ``r0 - r1 = (rho0 - rho1) - (e0 - e1)``: hypotheses that
share their quadratic part (eq. (6.17)'s reaching costs) have ``rho0 = rho1`` exactly, so the ratio
is exact for controls far beyond where the squares themselves lose it. What float64
cannot represent is refused (:class:`NotRepresentable`), never returned as NaN or inf.
"""

from dataclasses import dataclass

import numpy as np

from .riccati import LQStage, positive_definite, riccati_step

DENSE_LIMIT_BYTES = 2 * 2 ** 30        # the dense forms (checks on small problems) refuse above this
_HALF_LOG_2PI = 0.5 * np.log(2 * np.pi)


class NotRepresentable(ValueError):
    """A log-density or a ratio of them beyond float64's range (a ValueError naming the input)."""


def dense_bytes(N, m, n=0):
    """Bytes of the dense lifted forms of an N-step problem: the (N m)^2 Hessian and the (N+1, n, N m) map
    from the controls to the states."""
    return 8 * (N * m) * (N * m + (N + 1) * n)


def check_dense_size(N, m, n=0, what="the dense (N m)^2 form"):
    """Refuse, before allocating, a dense form over ``N`` steps that would exceed :data:`DENSE_LIMIT_BYTES`."""
    need = dense_bytes(N, m, n)
    if need > DENSE_LIMIT_BYTES:
        raise ValueError(f"N = {N} steps: {what} would need {need / 2 ** 30:.3g} GiB (limit "
                         f"{DENSE_LIMIT_BYTES / 2 ** 30:.3g} GiB); the banded forms of mutual.motion.chain serve any N")


def rollout(A, B, c, x0, us):
    """States ``x_0 .. x_N`` (..., N+1, n) of ``x_{t+1} = A_t x_t + B_t u_t + c_t`` for controls
    ``us`` (..., N, m) (a leading batch axis is allowed)."""
    N = us.shape[-2]
    xs = np.empty(us.shape[:-2] + (N + 1, A.shape[-1]))
    x = xs[..., 0, :] = x0
    for t in range(N):
        x = xs[..., t + 1, :] = x @ A[t].T + us[..., t, :] @ B[t].T + c[t]
    return xs


@dataclass(frozen=True, eq=False)
class ChainGaussian:
    """A Gaussian over stacked controls (N, m) factored by stage:
    ``u_t | u_{<t} ~ N(K_t x_t + k_t, (L_t L_t')^-1)`` along ``x_{t+1} = A_t x_t + B_t u_t + c_t`` from
    ``x0`` (module docstring). ``mean`` (N, m) is the mode (the optimal controls); ``A`` (N, n, n),
    ``B`` (N, n, m), ``c`` (N, n), ``K`` (N, m, n), ``k`` (N, m), ``L`` (N, m, m) lower triangular;
    ``half_logdets`` (N,) holds ``1/2 log det Q_uu,t``.

    Unpacks as ``mean, precision = gaussian`` (building the dense precision: small problems only).
    """

    A: np.ndarray
    B: np.ndarray
    c: np.ndarray
    x0: np.ndarray
    K: np.ndarray
    k: np.ndarray
    L: np.ndarray
    mean: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "_e", np.einsum("tji,tj->ti", self.L, self.k))
        object.__setattr__(self, "half_logdets", np.log(np.diagonal(self.L, axis1=1, axis2=2)).sum(axis=1))

    def __repr__(self):
        return f"ChainGaussian(N={self.N}, n={self.n}, m={self.m})"

    def __iter__(self):
        return iter((self.mean, self.precision()))

    @property
    def N(self):
        return self.mean.shape[0]

    @property
    def m(self):
        return self.mean.shape[1]

    @property
    def n(self):
        return self.A.shape[-1]

    def check_controls(self, us, name="us"):
        """``us`` as a finite (N, m) array, or a ValueError naming it."""
        us = np.asarray(us, float)
        if us.shape != self.mean.shape:
            raise ValueError(f"{name} must be an ({self.N}, {self.m}) array of controls, got shape {us.shape}")
        if not np.all(np.isfinite(us)):
            raise ValueError(f"{name} contains non-finite values (NaN or inf): the likelihood is undefined")
        return us

    def linear_part(self, us, xs=None):
        """``rho_t = L_t'(u_t - K_t x_t)`` (N, m), with ``x`` the rollout of ``us`` (``xs`` if given): the
        whitened residual is ``rho - L'k``."""
        if xs is None:
            xs = self.rollout(us)
        with np.errstate(over="ignore", invalid="ignore"):
            return np.einsum("tji,tj->ti", self.L, us - np.einsum("tij,tj->ti", self.K, xs[:-1]))

    def rollout(self, us):
        """The states (N+1, n) the policy feeds back on, reached by the controls ``us``."""
        with np.errstate(over="ignore", invalid="ignore"):
            return rollout(self.A, self.B, self.c, self.x0, us)

    def same_dynamics(self, other):
        """Do ``self`` and ``other`` feed back on the same states (same dynamics and start)?"""
        return all(a is b or np.array_equal(a, b) for a, b in
                   ((self.A, other.A), (self.B, other.B), (self.c, other.c), (self.x0, other.x0)))

    def stage_logliks(self, us, name="us"):
        """``log N(u_t; K_t x_t + k_t, Q_uu,t^-1)`` for each stage (N,); their running sums are the
        prefix marginals."""
        us = self.check_controls(us, name)
        with np.errstate(over="ignore", invalid="ignore"):
            r = self.linear_part(us) - self._e
            terms = -0.5 * _sum_squares(r) + self.half_logdets - self.m * _HALF_LOG_2PI
        return _representable(terms, name, "log P(u | H)")

    def prefix_loglik(self, us, name="us"):
        """``log P(u_{0:t})`` for ``t = 0 .. N`` (N+1,): entry 0 is 0, entry N the full log-density."""
        return np.concatenate([[0.0], _representable(np.cumsum(self.stage_logliks(us, name)), name,
                                                     "log P(u | H)")])

    def prefix_logdets(self):
        """``log det`` of the precision of ``u_{0:t}``'s marginal for ``t = 0 .. N`` (N+1,), i.e.
        ``log det H - log det H[t m:, t m:]``: running sums of ``log det Q_uu,t``."""
        return np.concatenate([[0.0], np.cumsum(2 * self.half_logdets)])

    def trailing_logdets(self):
        """``log det H[j:, j:]`` for ``j = 0 .. N m`` (N m + 1,): the trailing blocks' factors are the
        reversed Cholesky factors of each ``Q_uu,t``."""
        quu = self.L @ self.L.transpose(0, 2, 1)
        upper = np.linalg.cholesky(quu[:, ::-1, ::-1])[:, ::-1, ::-1]
        logs = 2 * np.log(np.diagonal(upper, axis1=1, axis2=2)).reshape(-1)
        return np.concatenate([np.cumsum(logs[::-1])[::-1], [0.0]])

    def whitening(self):
        """``(W, r0)`` with the whitened residual ``r = W u + r0`` (W (N m, N m), lower block-triangular;
        ``H = W'W``). Dense: for checks and dense solves on small problems."""
        N, n, m = self.N, self.n, self.m
        check_dense_size(N, m, n, "the dense whitening map")
        W = np.zeros((N * m, N * m))
        G = np.zeros((n, N * m))                                      # x_t's linear part in the controls
        for t in range(N):
            rows = slice(t * m, (t + 1) * m)
            W[rows] = -self.L[t].T @ self.K[t] @ G
            W[rows, rows] += self.L[t].T
            G = self.A[t] @ G
            G[:, rows] += self.B[t]
        return W, (self.linear_part(np.zeros((N, m))) - self._e).reshape(-1)

    def precision(self):
        """The dense precision ``H`` (N m, N m) (the Hessian of ``J``), refused beyond :data:`DENSE_LIMIT_BYTES`."""
        W, _ = self.whitening()
        return W.T @ W


def _sum_squares(r):
    """``sum_i r_i^2`` along the last axis, scaled before squaring so that it overflows only when the sum does."""
    scale = np.max(np.abs(r), axis=-1)
    safe = np.where(scale > 0, scale, 1.0)
    return scale * scale * np.sum((r / safe[..., None]) ** 2, axis=-1) if r.shape[-1] else np.zeros(r.shape[:-1])


def _representable(values, name, what):
    if not np.all(np.isfinite(values)):
        raise NotRepresentable(f"{name}: {what} of these controls is beyond float64's range (|value| > 1.8e308); "
                               "rescale the problem (its positions, weights or controls)")
    return values


def log_ratio_prefix(us, gaussian0, gaussian1, name="us"):
    """``log P0(u_{0:t}) - log P1(u_{0:t})`` for ``t = 0 .. N`` (N+1,) of two :class:`ChainGaussian` objects,
    as ``-1/2 (r0 - r1).(r0 + r1)`` per stage (module docstring): exact where the squares are not."""
    us = gaussian0.check_controls(us, name)
    gaussian1.check_controls(us, name)
    xs = gaussian0.rollout(us) if gaussian0.same_dynamics(gaussian1) else None
    with np.errstate(over="ignore", invalid="ignore"):
        rho0, rho1 = gaussian0.linear_part(us, xs), gaussian1.linear_part(us, xs)
        diff = (rho0 - rho1) - (gaussian0._e - gaussian1._e)
        total = (rho0 - gaussian0._e) + (rho1 - gaussian1._e)
        terms = -0.5 * np.sum(diff * total, axis=1) + (gaussian0.half_logdets - gaussian1.half_logdets)
        out = np.concatenate([[0.0], np.cumsum(terms)])
    return _representable(out, name, "the log-likelihood ratio")


def check_x0_N(dynamics, x0, N):
    """``x0`` as a finite state of ``dynamics`` (a LinearDynamics) and ``N`` a positive integer, or a ValueError."""
    if not hasattr(dynamics, "stages") or not hasattr(dynamics, "n"):
        raise ValueError(f"dynamics must be a LinearDynamics, got {type(dynamics).__name__}")
    if not isinstance(N, (int, np.integer)) or isinstance(N, bool) or N < 1:
        raise ValueError(f"N must be a positive integer, got {N!r}")
    x0 = np.asarray(x0, float)
    if x0.shape != (dynamics.n,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be a finite vector of length {dynamics.n}, got {x0!r}")
    return x0


def lq_chains(dynamics, costs, x0, N):
    """The exact Gaussians ``P(u | H_i)`` of eq. (6.8) (one :class:`ChainGaussian` per cost) for linear
    dynamics (a :class:`mutual.motion.legible.LinearDynamics`) and quadratic costs (``QuadraticCost``s)
    from ``x0`` over ``N`` steps: one batched Riccati backward pass for all of them."""
    x0 = check_x0_N(dynamics, x0, N)
    dyn = dynamics.stages(0, N)
    n, m = dyn.n, dyn.m
    cs = [cost.stages(0, N) for cost in costs]
    for cost in cs:
        if (cost.QN.shape[0], cost.R.shape[-1]) != (n, m):
            raise ValueError(f"the cost is for n = {cost.QN.shape[0]} states and m = {cost.R.shape[-1]} controls, "
                             f"the dynamics have n = {n}, m = {m}")

    def stacked(f, shape):
        return np.stack([np.broadcast_to(getattr(cost, f), shape) for cost in cs])

    A, B = np.broadcast_to(dyn.A, (N, n, n)), np.broadcast_to(dyn.B, (N, n, m))
    Hz = np.zeros((len(cs), N, n + m, n + m))
    Hz[:, :, :n, :n], Hz[:, :, n:, n:] = stacked("Q", (N, n, n)), stacked("R", (N, m, m))
    gz = np.concatenate([stacked("q", (N, n)), stacked("r", (N, m))], axis=2)
    K, k, L = riccati_factor(A, B, Hz, gz, stacked("QN", (n, n)), stacked("qN", (n,)),
                             "exp(-J) is not normalisable, so P(u | H) of eq. (6.8) is undefined")
    us = np.empty((len(cs), N, m))
    x = np.broadcast_to(x0, (len(cs), n))
    for t in range(N):                                   # the modes: every policy rolled out at once
        u = us[:, t] = np.einsum("pij,pj->pi", K[:, t], x) + k[:, t]
        x = x @ A[t].T + u @ B[t].T
    c = np.broadcast_to(np.zeros(n), (N, n))
    return [ChainGaussian(A, B, c, x0, K[i], k[i], L[i], us[i]) for i in range(len(cs))]


def riccati_factor(A, B, Hz, gz, VN, vN, what="the cost"):
    """The Riccati backward pass of ``P`` problems sharing the dynamics ``A`` (N, n, n), ``B`` (N, n, m):
    stage costs ``1/2 z'Hz z + gz'z`` in ``z = (x, u)`` (``Hz`` (P, N, n+m, n+m), ``gz`` (P, N, n+m)),
    terminal ``1/2 x'VN x + vN'x``; each stage is :func:`mutual.motion.riccati.riccati_step`. Returns the
    policy ``u = K x + k`` (``K`` (P, N, m, n), ``k`` (P, N, m)) and the lower Cholesky factors ``L``
    (P, N, m, m) of ``Q_uu``. A ``Q_uu`` that is not positive definite (the precision is not, eq. (6.8) has
    no density) raises a ValueError naming ``what`` and the stage."""
    P, N = Hz.shape[:2]
    n, m = B.shape[-2:]
    K, k, L = np.empty((P, N, m, n)), np.empty((P, N, m)), np.empty((P, N, m, m))
    Quu = np.empty((P, N, m, m))
    V, v = np.array(VN, float), np.array(vN, float)
    F = np.concatenate([A, B], axis=2)
    with np.errstate(over="ignore", invalid="ignore"):
        for t in range(N - 1, -1, -1):
            step = riccati_step(V, v, LQStage(F=F[t], H=Hz[:, t], g=gz[:, t]))
            K[:, t], k[:, t], L[:, t], Quu[:, t] = step.K, step.k, step.L, step.Q_uu
            V, v = step.V, step.v
    # the first stage (from the end) whose finite Q_uu has no Cholesky factor; the stages before it are NaN
    refused = ~positive_definite(L) & np.isfinite(Quu).all(axis=(-2, -1))
    if refused.any():
        raise ValueError(f"{what}: its control Hessian Q_uu = R + B'VB at stage {np.nonzero(refused)[1].max()} is "
                         "not positive definite")
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(k)) and np.all(np.isfinite(L))):
        raise NotRepresentable(f"{what}: the Riccati backward pass overflowed float64; rescale the problem "
                               "(its positions, weights or time step)")
    return K, k, L
