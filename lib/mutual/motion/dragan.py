"""The prior art: Dragan & Srinivasa's legible motion (RSS 2013, "Generating Legible Motion").

A trajectory ``xi`` from ``S`` to the robot's goal ``G_R`` is a polyline of
``N + 1`` configurations over the duration ``T``; its cost is the sum of squared
velocities ``C[xi] = 1/2 int |xi'|^2 dt``. The observer infers the goal from a
partial trajectory ``xi_{S->Q}`` by

    P(G | xi_{S->Q})  proportional to  exp(V_G(S) - V_G(Q)) P(G),

(the common factor ``exp(-C[xi_{S->Q}])`` cancels), with ``V_G`` the optimal
cost-to-go of ``C``: a straight line over unit duration, ``V_G(q) = |G - q|^2 / 2``.
The legibility score is

    Legibility[xi] = int P(G_R | xi_{S->xi(t)}) f(t) dt / int f(t) dt,  f(t) = T - t,

maximised by functional gradient ascent in the metric ``M`` of ``C``
(``xi <- xi + M^{-1} grad / eta``) inside the predictability trust region
``C[xi] <= beta`` (the constraint enters through a Lagrange multiplier chosen so
that the linearised constraint holds with equality when it is active).
"""

from dataclasses import dataclass

import numpy as np
from scipy.special import softmax


def _goals(goals):
    g = np.asarray(goals, float)
    if g.ndim != 2 or len(g) < 2 or not np.all(np.isfinite(g)):
        raise ValueError(f"goals must be a finite (n_goals >= 2, dim) array, got shape {g.shape}")
    return g


def _prior(prior, n_goals):
    if prior is None:
        return np.full(n_goals, 1.0 / n_goals)
    p = np.asarray(prior, float)
    if p.shape != (n_goals,) or np.any(p <= 0):
        raise ValueError(f"prior must be {n_goals} positive probabilities, got {prior!r}")
    return p / p.sum()


def goal_posterior(points, start, goals, prior=None):
    """``P(G | xi_{S->q})`` for every point ``q`` of ``points`` (..., dim) and goal; shape (..., n_goals)."""
    goals = _goals(goals)
    q = np.asarray(points, float)
    start = np.asarray(start, float)
    logits = (0.5 * np.sum((goals - start) ** 2, axis=-1)              # V_G(S)
              - 0.5 * np.sum((q[..., None, :] - goals) ** 2, axis=-1)  # V_G(q)
              + np.log(_prior(prior, len(goals))))
    return softmax(logits, axis=-1)


def score_weights(N, T=1.0):
    """Trapezoid weights of ``int (.) f(t) dt / int f(t) dt`` with ``f(t) = T - t`` on ``N + 1`` knots."""
    t = np.linspace(0.0, T, N + 1)
    w = (T - t) * np.full(N + 1, T / N)
    w[[0, -1]] *= 0.5
    return w / w.sum()


def legibility_score(xs, goals, goal_index, prior=None, T=1.0):
    """Dragan & Srinivasa's legibility of the trajectory ``xs`` (N+1, dim) for goal ``goal_index``."""
    xs = np.asarray(xs, float)
    post = goal_posterior(xs, xs[0], goals, prior)[:, goal_index]
    return float(score_weights(len(xs) - 1, T) @ post)


def trajectory_cost(xs, T=1.0):
    """``C[xi] = 1/2 int |xi'|^2 dt`` of the polyline ``xs`` traversed uniformly in time ``T``."""
    xs = np.asarray(xs, float)
    dt = T / (len(xs) - 1)
    return float(0.5 * np.sum(np.diff(xs, axis=0) ** 2) / dt)


def score_gradient(xs, goals, goal_index, prior=None, T=1.0):
    """Gradient of :func:`legibility_score` with respect to the interior knots ``xs[1:-1]``.

    ``P(G_R | q)`` depends on the partial trajectory only through its end ``q``, and
    ``dP(G_R|q)/dq = P(G_R|q) (G_R - sum_G P(G|q) G)`` since ``-dV_G/dq = G - q``.
    """
    xs = np.asarray(xs, float)
    goals = _goals(goals)
    post = goal_posterior(xs[1:-1], xs[0], goals, prior)
    w = score_weights(len(xs) - 1, T)[1:-1, None]
    return w * post[:, [goal_index]] * (goals[goal_index] - post @ goals)


@dataclass(frozen=True)
class DraganResult:
    """Optimised trajectory ``xs`` (N+1, dim), the score and the cost ``C`` before the first and
    after every iteration, and the number of iterations."""

    xs: np.ndarray
    scores: np.ndarray
    costs: np.ndarray
    iterations: int


def optimise_legibility(start, goals, goal_index, N=100, beta=None, beta_ratio=1.5, eta=0.3, max_iter=2000,
                        tol=1e-9, prior=None, T=1.0):
    """Functional-gradient legibility optimisation with the trust region ``C[xi] <= beta``.

    Starts from the predictable (straight-line, cost-optimal) trajectory; ``beta``
    defaults to ``beta_ratio`` times its cost. Stops after ``max_iter`` iterations
    or when an iteration improves the score by less than ``tol``.
    """
    goals = _goals(goals)
    start = np.asarray(start, float)
    if not 0 <= goal_index < len(goals):
        raise ValueError(f"goal_index must index goals (0..{len(goals) - 1}), got {goal_index!r}")
    if not (isinstance(N, (int, np.integer)) and N >= 2):
        raise ValueError(f"N must be an integer >= 2, got {N!r}")
    if not eta > 0:
        raise ValueError(f"eta must be positive, got {eta!r}")
    goal = goals[goal_index]
    dt = T / N
    xs = start + np.linspace(0.0, 1.0, N + 1)[:, None] * (goal - start)
    c_star = trajectory_cost(xs, T)
    beta = beta_ratio * c_star if beta is None else beta
    if not beta >= c_star:
        raise ValueError(f"beta = {beta!r} is below the least possible cost {c_star:.4g}: empty trust region")
    # The metric M of C over the interior knots, tridiagonal (2, -1, -1) / dt; M^-1 applied densely.
    metric = (2 * np.eye(N - 1) - np.eye(N - 1, k=1) - np.eye(N - 1, k=-1)) / dt
    Minv = np.linalg.inv(metric)
    prior_p = _prior(prior, len(goals))
    scores, costs = [legibility_score(xs, goals, goal_index, prior_p, T)], [c_star]
    for _ in range(max_iter):
        inner = xs[1:-1]
        grad_L = score_gradient(xs, goals, goal_index, prior_p, T)
        grad_C = (2 * inner - xs[:-2] - xs[2:]) / dt
        step_L, step_C = Minv @ grad_L, Minv @ grad_C
        cost = trajectory_cost(xs, T)
        # multiplier that makes the linearised constraint C + grad_C . step = beta hold with equality
        lam = (np.sum(grad_C * step_L) - eta * (beta - cost)) / np.sum(grad_C * step_C)
        if cost + np.sum(grad_C * step_L) / eta > beta:                   # trust region active
            xs[1:-1] = inner + (step_L - max(lam, 0.0) * step_C) / eta
        else:
            xs[1:-1] = inner + step_L / eta
        scores.append(legibility_score(xs, goals, goal_index, prior_p, T))
        costs.append(trajectory_cost(xs, T))
        if abs(scores[-1] - scores[-2]) < tol:
            break
    return DraganResult(xs=xs, scores=np.array(scores), costs=np.array(costs), iterations=len(scores) - 1)


def single_integrator_controls(xs, T=1.0):
    """The controls ``u_k = (xi_{k+1} - xi_k) / dt`` that make x' = u (eq. (6.5)) trace the polyline,
    so a Dragan-Srinivasa trajectory can be scored by the likelihood ratio of chapter 6."""
    xs = np.asarray(xs, float)
    return np.diff(xs, axis=0) * ((len(xs) - 1) / T)
