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
that the linearised constraint holds with equality when it is active). ``M`` is
tridiagonal, so ``M^{-1} grad`` is one banded Cholesky solve (``solveh_banded``), O(N).
"""

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solveh_banded
from scipy.special import softmax

from ...inputs import positive


def _goals(goals):
    g = np.asarray(goals, float)
    if g.ndim != 2 or len(g) < 2 or not np.all(np.isfinite(g)):
        raise ValueError(f"goals must be a finite (n_goals >= 2, dim) array, got shape {g.shape}")
    return g


def _goal_index(goal_index, n_goals):
    if not isinstance(goal_index, (int, np.integer)) or isinstance(goal_index, bool) or not 0 <= goal_index < n_goals:
        raise ValueError(f"goal_index must index goals (an integer 0..{n_goals - 1}), got {goal_index!r}")
    return int(goal_index)


def _trajectory(xs, dim=None, name="xs"):
    xs = np.asarray(xs, float)
    if xs.ndim != 2 or len(xs) < 2 or (dim is not None and xs.shape[1] != dim):
        want = f"(N+1 >= 2, {dim})" if dim is not None else "(N+1 >= 2, dim)"
        raise ValueError(f"{name} must be a {want} trajectory, got shape {xs.shape}")
    if not np.all(np.isfinite(xs)):
        raise ValueError(f"{name} contains non-finite values (NaN or inf)")
    return xs


def _point(name, value, dim):
    a = np.asarray(value, float)
    if a.shape[-1:] != (dim,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite with last dimension {dim} (that of the goals), got {value!r}")
    return a


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
    q = _point("points", points, goals.shape[1])
    start = _point("start", start, goals.shape[1])
    logits = (0.5 * np.sum((goals - start) ** 2, axis=-1)              # V_G(S)
              - 0.5 * np.sum((q[..., None, :] - goals) ** 2, axis=-1)  # V_G(q)
              + np.log(_prior(prior, len(goals))))
    return softmax(logits, axis=-1)


def score_weights(N, T=1.0):
    """Trapezoid weights of ``int (.) f(t) dt / int f(t) dt`` with ``f(t) = T - t`` on ``N + 1`` knots."""
    if not isinstance(N, (int, np.integer)) or N < 1:
        raise ValueError(f"N must be a positive integer, got {N!r}")
    T = positive("T", T)
    t = np.linspace(0.0, T, N + 1)
    w = (T - t) * np.full(N + 1, T / N)
    w[[0, -1]] *= 0.5
    return w / w.sum()


def legibility_score(xs, goals, goal_index, prior=None, T=1.0):
    """Dragan & Srinivasa's legibility of the trajectory ``xs`` (N+1, dim) for goal ``goal_index``."""
    goals = _goals(goals)
    xs = _trajectory(xs, goals.shape[1])
    goal_index = _goal_index(goal_index, len(goals))
    post = goal_posterior(xs, xs[0], goals, prior)[:, goal_index]
    return float(score_weights(len(xs) - 1, T) @ post)


def trajectory_cost(xs, T=1.0):
    """``C[xi] = 1/2 int |xi'|^2 dt`` of the polyline ``xs`` traversed uniformly in time ``T``."""
    xs = _trajectory(xs)
    T = positive("T", T)
    dt = T / (len(xs) - 1)
    return float(0.5 * np.sum(np.diff(xs, axis=0) ** 2) / dt)


def score_gradient(xs, goals, goal_index, prior=None, T=1.0):
    """Gradient of :func:`legibility_score` with respect to the interior knots ``xs[1:-1]``.

    ``P(G_R | q)`` depends on the partial trajectory only through its end ``q``, and
    ``dP(G_R|q)/dq = P(G_R|q) (G_R - sum_G P(G|q) G)`` since ``-dV_G/dq = G - q``.
    """
    goals = _goals(goals)
    xs = _trajectory(xs, goals.shape[1])
    goal_index = _goal_index(goal_index, len(goals))
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

    def __repr__(self):
        return (f"DraganResult(N={len(self.xs) - 1}, dim={self.xs.shape[1]}, iterations={self.iterations}, "
                f"score {self.scores[0]:.4f} -> {self.scores[-1]:.4f}, cost {self.costs[0]:.4g} -> {self.costs[-1]:.4g})")


def optimise_legibility(start, goals, goal_index, N=100, beta=None, beta_ratio=1.5, eta=0.3, max_iter=2000,
                        tol=1e-9, prior=None, T=1.0):
    """Functional-gradient legibility optimisation with the trust region ``C[xi] <= beta``.

    Starts from the predictable (straight-line, cost-optimal) trajectory; ``beta``
    defaults to ``beta_ratio`` times its cost. Stops after ``max_iter`` iterations
    or when an iteration improves the score by less than ``tol``.
    """
    goals = _goals(goals)
    start = _point("start", start, goals.shape[1])
    if start.ndim != 1:
        raise ValueError(f"start must be one configuration (a vector of length {goals.shape[1]}), got shape {start.shape}")
    goal_index = _goal_index(goal_index, len(goals))
    if not (isinstance(N, (int, np.integer)) and N >= 2):
        raise ValueError(f"N must be an integer >= 2, got {N!r}")
    eta, T = positive("eta", eta), positive("T", T)
    if not (isinstance(max_iter, (int, np.integer)) and max_iter >= 0):
        raise ValueError(f"max_iter must be a non-negative integer, got {max_iter!r}")
    if not (np.isfinite(tol) and tol >= 0):
        raise ValueError(f"tol must be a finite number >= 0, got {tol!r}")
    goal = goals[goal_index]
    if np.allclose(goal, start):
        raise ValueError("start coincides with the chosen goal: there is no motion to make legible")
    dt = T / N
    xs = start + np.linspace(0.0, 1.0, N + 1)[:, None] * (goal - start)
    c_star = trajectory_cost(xs, T)
    if beta is None:
        if not (np.isfinite(beta_ratio) and beta_ratio >= 1):
            raise ValueError(f"beta_ratio must be a finite number >= 1 (beta = beta_ratio C*), got {beta_ratio!r}")
        beta = beta_ratio * c_star
    if not (np.isfinite(beta) and beta >= c_star):
        raise ValueError(f"beta = {beta!r} is not finite or below the least possible cost {c_star:.4g}: "
                         "empty trust region")
    # The metric M of C over the interior knots, tridiagonal (2, -1, -1) / dt, in banded (upper) storage.
    metric = np.empty((2, N - 1))
    metric[0], metric[1] = -1.0 / dt, 2.0 / dt
    metric[0, 0] = 0.0
    prior_p = _prior(prior, len(goals))
    scores, costs = [legibility_score(xs, goals, goal_index, prior_p, T)], [c_star]
    d = len(start)
    for _ in range(max_iter):
        inner = xs[1:-1]
        grad_L = score_gradient(xs, goals, goal_index, prior_p, T)
        grad_C = (2 * inner - xs[:-2] - xs[2:]) / dt
        steps = solveh_banded(metric, np.hstack([grad_L, grad_C]), check_finite=False)
        step_L, step_C = steps[:, :d], steps[:, d:]
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
    xs = _trajectory(xs)
    T = positive("T", T)
    return np.diff(xs, axis=0) * ((len(xs) - 1) / T)


def gradient_linear_structure(xs, goals, goal_index, prior=None, T=1.0, eps=1e-3):
    """Dragan & Srinivasa's eq. 11 gradient as a linear combination of the hypotheses' cost gradients.

    The gradient of :func:`legibility_score` with respect to each interior knot ``q`` is taken by
    fourth-order central differences of the score itself (step ``eps``; not from
    :func:`score_gradient`), then fitted by
    least squares as ``sum_G c_G grad V_G(q)`` with ``grad V_G(q) = q - G``. Section 6.5 reads eq. 11
    as the structure of eq. (6.13): well on the truth (``c_R <= 0``), poorly on the distractors
    (``c_G >= 0``), with weights that cancel (``sum_G c_G = 0``) and that D&S must compute from the
    posteriors: ``c_G = w(t) P(G_R|q) P(G|q)`` for ``G != G_R``.

    Returns a dict: ``coefficients`` (N-1, n_goals), ``predicted`` (the same from the posteriors),
    ``residual`` (largest |gradient - fit| / |gradient| over knots), ``sum_ratio`` (largest
    |sum_G c_G| / max_G |c_G|) and ``signs_ok`` (truth <= 0 <= distractors at every knot).
    Use ``dim > n_goals`` so the fit is overdetermined and the check can fail.
    """
    goals = _goals(goals)
    xs = _trajectory(xs, goals.shape[1])
    goal_index = _goal_index(goal_index, len(goals))
    eps = positive("eps", eps)
    N, d = len(xs) - 1, goals.shape[1]
    grad = np.zeros((N - 1, d))
    def score_at(k, j, step):
        moved = xs.copy()
        moved[k, j] += step
        return legibility_score(moved, goals, goal_index, prior, T)

    for k in range(1, N):
        for j in range(d):
            grad[k - 1, j] = (-score_at(k, j, 2 * eps) + 8 * score_at(k, j, eps) - 8 * score_at(k, j, -eps)
                              + score_at(k, j, -2 * eps)) / (12 * eps)
    coef, residual = np.zeros((N - 1, len(goals))), 0.0
    for k in range(N - 1):
        basis = (xs[k + 1] - goals).T                               # columns grad V_G(q)
        c, *_ = np.linalg.lstsq(basis, grad[k], rcond=None)
        coef[k] = c
        norm = np.linalg.norm(grad[k])
        if norm > 0:
            residual = max(residual, np.linalg.norm(basis @ c - grad[k]) / norm)
    post = goal_posterior(xs[1:-1], xs[0], goals, prior)
    w = score_weights(N, T)[1:-1, None]
    predicted = w * post[:, [goal_index]] * post
    predicted[:, goal_index] = -(w[:, 0] * post[:, goal_index] * (1 - post[:, goal_index]))
    others = np.delete(coef, goal_index, axis=1)
    scale = np.abs(coef).max(axis=1)
    sum_ratio = float(np.max(np.abs(coef.sum(axis=1)) / np.where(scale > 0, scale, 1.0)))
    tol = 1e-6 * np.abs(coef).max()
    signs_ok = bool(np.all(coef[:, goal_index] <= tol) and np.all(others >= -tol))
    return {"coefficients": coef, "predicted": predicted, "residual": float(residual),
            "sum_ratio": sum_ratio, "signs_ok": signs_ok}
