"""Legible motion as hypothesis testing for linear-quadratic hypotheses (chapter 6).

An observer decides between hypotheses ``H_i``, each an optimal-control problem
with cost ``J_i`` (eq. (6.3)); it models the robot's controls as Boltzmann
distributed, ``P(u | H_i) = exp(-J_i(u)) / Z_i`` (eq. (6.8)). By Theorem 6.4.2
the likelihood ratio ``Lambda = P(u|H0) / P(u|H1)`` (eq. (6.7)) has the same
minimisers as ``J1 - J0`` (eq. (6.13)); weighting the task, ``(1 + alpha) J1 - J0``
(eq. (6.15)). For linear dynamics and quadratic costs (:mod:`.problem`) this is one LQ
problem, solved exactly by the Riccati recursion (:mod:`.lqr`); anticipation replans it on
a receding horizon (eq. (6.16)); several distractors at once are the QP of :mod:`.qp`.
"""

import numpy as np

from .lqr import riccati_backward
from .problem import QuadraticCost, check_lq_problem, solve


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


def inverse_square_alpha_schedule(alpha_start):
    """``alpha(s) = alpha_start / (1 - s)^2`` for eq. (6.16), ``s = t / T``: the weighting that Dragan and
    Srinivasa's ``f(t) = T - t`` on partial viewings amounts to (section 6.5; the notebook recovers it from
    their weighted optimum), rising without bound so that the last replans serve the task alone."""
    if not (np.isfinite(alpha_start) and alpha_start > 0):
        raise ValueError(f"need a finite alpha_start > 0, got {alpha_start!r}")
    return lambda s: alpha_start / (1.0 - s) ** 2


def replan_gains(dynamics, J1, J0, N, w1, w0, starts):
    """Feedback gains of the replans ``min w1[p] J1 - w0[p] J0`` on ``[starts[p], N)`` (eq. (6.16)),
    all from one batched backward sweep (:func:`.lqr.riccati_backward`): returns
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
    next replanning. A replan's gains at a stage do not depend on where it started (the
    backward pass runs from ``N``), and the closed loop applies plan ``i``'s feedback on its own
    steps, which reproduces its open-loop controls exactly. When ``J1`` and ``J0`` share their
    quadratic part (eq. (6.17)'s reaching costs), every replan's gains follow from the two
    hypotheses' own (:func:`shared_quadratic_gains`): O(N) for any ``every``; otherwise the replans'
    backward passes run together in one batched sweep (:func:`.lqr.riccati_backward`), whose size
    (``N / every`` passes of ``N`` stages) is checked before allocating.
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
    check_lq_problem(dynamics, J1, N)
    check_lq_problem(dynamics, J0, N)
    x0 = np.asarray(x0, float)
    if x0.shape != (dynamics.n,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be a finite vector of length {dynamics.n}, got {x0!r}")
    per_step = scheduled_alphas(alpha_of_s, N, every)
    dyn = dynamics.stages(0, N)
    n, m = dyn.n, dyn.m
    if shares_quadratic(J1, J0, N):
        Ks, ks = shared_quadratic_gains(dynamics, J1, J0, N, 1.0 + per_step, np.ones(N))
    else:
        starts = np.arange(0, N, every)
        need = 8 * len(starts) * (N + 1) * (3 * n * n + 3 * m * m + 2 * n * m + 2 * n + 2 * m)
        if need > REPLAN_LIMIT_BYTES:
            raise ValueError(f"receding horizon: {len(starts)} replans (N = {N}, every = {every}) of costs without a "
                             f"shared quadratic part need one batched sweep of {need / 2 ** 30:.3g} GiB (limit "
                             f"{REPLAN_LIMIT_BYTES / 2 ** 30:.3g} GiB); replan less often (a larger every)")
        K, k = replan_gains(dynamics, J1, J0, N, 1.0 + per_step[starts], np.ones(len(starts)), starts)
        plan = np.arange(N) // every            # which replan is in force at each step
        Ks, ks = K[plan, np.arange(N)], k[plan, np.arange(N)]
    xs, us = policy_rollout(dynamics, x0, Ks, ks)
    return xs, us, per_step


def scheduled_alphas(alpha_of_s, N, every):
    """The weight in force at each step (N,) when replanning at ``t_i = 0, every, ...`` with
    ``alpha_i = alpha_of_s(t_i / N)`` (eq. (6.16))."""
    alphas = np.array([float(alpha_of_s(t / N)) for t in range(0, N, every)])
    if not np.all(np.isfinite(alphas)):
        raise ValueError(f"alpha_of_s returned non-finite weights {alphas.tolist()}")
    return alphas[np.arange(N) // every]


def policy_rollout(dynamics, x0, K, k):
    """States (N+1, n) and controls (N, m) of the affine policy ``u_t = K_t x_t + k_t`` from ``x0``."""
    N = len(k)
    dyn = dynamics.stages(0, N)
    n, m = dyn.n, dyn.m
    A, B = np.broadcast_to(dyn.A, (N, n, n)), np.broadcast_to(dyn.B, (N, n, m))
    xs = np.empty((N + 1, n))
    us = np.empty((N, m))
    x = xs[0] = np.asarray(x0, float)
    for t in range(N):
        u = us[t] = K[t] @ x + k[t]
        x = xs[t + 1] = A[t] @ x + B[t] @ u
    return xs, us


REPLAN_LIMIT_BYTES = 2 * 2 ** 30
SHARED_RTOL = 1e-13


def shares_quadratic(J1, J0, N, rtol=SHARED_RTOL):
    """Do ``J1`` and ``J0`` have the same quadratic part (``Q``, ``R``, ``QN`` over the first ``N`` stages,
    to a relative ``rtol``, i.e. rounding)? Then they differ only in their linear terms."""
    c1, c0 = J1.stages(0, N), J0.stages(0, N)
    for f in ("Q", "R", "QN"):
        a, b = np.broadcast_arrays(getattr(c1, f), getattr(c0, f))
        scale = max(np.abs(a).max(initial=0.0), np.abs(b).max(initial=0.0))
        if np.abs(a - b).max(initial=0.0) > rtol * scale:
            return False
    return True


def shared_quadratic_gains(dynamics, J1, J0, N, w1, w0):
    """Gains ``(K (N, m, n), k (N, m))`` at each stage ``t`` of ``min w1[t] J1 - w0[t] J0`` when ``J1`` and
    ``J0`` share their quadratic part ``J_q`` (:func:`shares_quadratic`; ``w1 > w0``): the cost's quadratic
    part is ``(w1 - w0) J_q``, which scales the Riccati matrices and leaves the feedback ``K`` that of
    ``J1`` alone, and the feedforward is linear in the linear terms, so
    ``k = (w1 k_1 - w0 k_0) / (w1 - w0)`` from the two hypotheses' own feedforwards ``k_i``: one batched
    backward pass for any number of weights (every replan of eq. (6.16))."""
    dyn, c1, c0 = dynamics.stages(0, N), J1.stages(0, N), J0.stages(0, N)
    n, m = dyn.n, dyn.m

    def both(f, shape):
        return np.stack([np.broadcast_to(getattr(c, f), shape) for c in (c1, c0)])

    A, B = np.broadcast_to(dyn.A, (N, n, n)), np.broadcast_to(dyn.B, (N, n, m))
    K, k, _, _ = riccati_backward(A, B, both("Q", (N, n, n)), both("R", (N, m, m)), both("q", (N, n)),
                                  both("r", (N, m)), both("QN", (n, n)), both("qN", (n,)))
    return K[0], mixed_feedforward(k[0], k[1], w1, w0)


def mixed_feedforward(k1, k0, w1, w0):
    """The feedforward ``(w1 k1 - w0 k0) / (w1 - w0)`` (N, m) of ``w1 J1 - w0 J0`` at each step from those of
    two costs that share their quadratic part (:func:`shared_quadratic_gains`); ``w1``, ``w0`` per step."""
    w1, w0 = np.broadcast_to(np.asarray(w1, float), (len(k1),)), np.broadcast_to(np.asarray(w0, float), (len(k1),))
    if not np.all(w1 - w0 > 0):
        raise ValueError("unbounded LQ problem: the weights give the shared quadratic part a factor w1 - w0 <= 0 "
                         "(for a legible objective (1+alpha) J1 - J0 this means alpha <= 0)")
    return (w1[:, None] * k1 - w0[:, None] * k0) / (w1 - w0)[:, None]
