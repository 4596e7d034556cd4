"""What chapter 6 says about its observer, checked on problems small enough to compute exactly.

* :func:`most_powerful_check` -- lines 1151 and 1372: the likelihood-ratio test is the most powerful test
  of one simple hypothesis against another (Neyman-Pearson). On the discrete problems of
  :func:`mutual.motion.legible.verify.random_discrete_hypotheses`, the power of the (randomised) test that
  rejects ``H0`` for small ``Lambda`` against the best power of any randomised test of that level, found by
  a linear programme that never forms the ratio.
* :func:`order_preserving_check` -- line 1216: "an objective can be composed with any non-decreasing
  function and have equivalent optima", as printed and with *strictly increasing* in its place.
* :func:`log_partition_quadrature`, :func:`posterior_partition_effect` -- lines 1166 and 1247: the
  observer's posterior ``P(H1 | u) = 1 / (1 + Lambda(u))`` needs the partition functions ``Z_i``; for
  eq. (6.17), ``log Z_1 - log Z_0 = J_0^* - J_1^*``, zero only for goals equally far from the start.
* :func:`prior_sensitivity` -- line 1388: the minimiser of ``Lambda`` takes no prior; Dragan and
  Srinivasa's posterior-weighted optimum does.
"""

import numpy as np
from scipy.optimize import linprog

from ..observer import lifted_cost
from .dragan import optimise_legibility
from .problem import reaching_cost, single_integrator, solve
from .verify import exact_log_probabilities


def _lrt_power(log_p0, log_p1, level):
    """Power of the test that rejects ``H0`` for the smallest ``Lambda = P0 / P1`` first, randomised on the
    group of equal ratios at its threshold so that its size is exactly ``level``."""
    p0, p1 = np.exp(log_p0), np.exp(log_p1)
    ratio = np.round(log_p0 - log_p1, 12)
    groups, inverse = np.unique(ratio, return_inverse=True)
    size0, size1 = np.bincount(inverse, p0), np.bincount(inverse, p1)
    cum0 = np.concatenate([[0.0], np.cumsum(size0)])
    k = int(np.searchsorted(cum0, level, side="right")) - 1          # groups 0 .. k-1 rejected whole
    if k >= len(groups):
        return float(p1.sum())
    fraction = (level - cum0[k]) / size0[k]
    return float(size1[:k].sum() + fraction * size1[k])


def _best_power(log_p0, log_p1, level):
    """``max sum phi P1`` subject to ``sum phi P0 <= level``, ``0 <= phi <= 1`` (scipy's HiGHS). The size
    constraint is written in units of a thousandth of the level: HiGHS's feasibility tolerance is absolute,
    and unscaled it lets the test exceed its level by some 1e-9 (and gain as much power)."""
    p0, p1 = np.exp(log_p0), np.exp(log_p1)
    result = linprog(-p1, A_ub=(1e3 * p0 / level)[None], b_ub=[1e3], bounds=(0, 1), method="highs",
                     options={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10})
    if result.status != 0:
        raise ValueError(f"the linear programme of the most powerful test failed: {result.message}")
    return float(-result.fun)


def most_powerful_check(hypotheses, levels=(0.01, 0.05, 0.1, 0.2, 0.5), T=8):
    """Per level: the likelihood-ratio test's power, the best power of any randomised test of that level (a
    linear programme over all ``3^T`` sequences) and their difference. A list of dicts."""
    log_p0, log_p1 = exact_log_probabilities(hypotheses, T)
    rows = []
    for level in levels:
        if not 0 < level < 1:
            raise ValueError(f"levels must lie in (0, 1), got {level!r}")
        lrt, best = _lrt_power(log_p0, log_p1, level), _best_power(log_p0, log_p1, level)
        rows.append({"level": level, "power LRT": lrt, "power best test": best, "gap": abs(lrt - best)})
    return rows


def _minimisers(values, rtol=1e-12):
    values = np.asarray(values, float)
    low = values.min()
    return frozenset(np.flatnonzero(values <= low + rtol * max(1.0, abs(low))).tolist())


# phi(Lambda), each written through t = log Lambda so that nothing underflows (a strictly increasing map of
# phi(Lambda), which has the same minimisers): Lambda spans hundreds of orders of magnitude here
ORDER_FUNCTIONS = {
    "constant (non-decreasing)": lambda t: np.zeros_like(t),
    "clamp at the median (non-decreasing)": lambda t: np.minimum(t, np.median(t)),
    "floor at the median (non-decreasing)": lambda t: np.maximum(t, np.median(t)),
    "log (strictly increasing)": lambda t: t,
    "cube (strictly increasing)": lambda t: 3 * t,
    "Lambda / (1 + Lambda) (strictly increasing)": lambda t: -np.logaddexp(0.0, -t),
}


def order_preserving_check(hypotheses, T=8):
    """For each function of :data:`ORDER_FUNCTIONS`: whether ``phi(Lambda)`` has exactly the minimisers of
    ``Lambda`` over all ``3^T`` sequences (``Lambda`` from the exact probabilities) and how many it has."""
    log_p0, log_p1 = exact_log_probabilities(hypotheses, T)
    t = log_p0 - log_p1
    best = _minimisers(t)
    out = {}
    for name, phi in ORDER_FUNCTIONS.items():
        mins = _minimisers(phi(t))
        out[name] = {"same minimisers": mins == best, "minimisers": len(mins)}
    return out


def log_partition_quadrature(dynamics, cost, x0, N, points=81, width=9.0):
    """``log Z = log int exp(-J(u)) du`` (eq. (6.9)) by the trapezoid rule on a tensor grid of ``points`` per
    control, ``width`` standard deviations either side of the minimiser (one control, ``N <= 3``), against the
    Gaussian closed form ``-c + h'H^-1 h / 2 + d/2 log 2 pi - log det H / 2``. Returns ``(quadrature, closed)``."""
    if dynamics.m != 1 or not 1 <= N <= 3:
        raise ValueError(f"quadrature needs one control and N <= 3 steps, got m = {dynamics.m}, N = {N}")
    H, h, c = lifted_cost(dynamics, cost, x0, N)
    mean = -np.linalg.solve(H, h)
    sd = np.sqrt(np.diag(np.linalg.inv(H)))
    axes = [np.linspace(mu - width * s, mu + width * s, points) for mu, s in zip(mean, sd)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, N)
    J = 0.5 * np.einsum("ki,ij,kj->k", grid, H, grid) + grid @ h + c
    J_min = 0.5 * mean @ H @ mean + mean @ h + c
    weights = np.ones(points)
    weights[[0, -1]] = 0.5
    w = np.prod(np.stack(np.meshgrid(*[weights * (a[1] - a[0]) for a in axes], indexing="ij"), -1).reshape(-1, N), axis=1)
    quadrature = np.log(np.sum(w * np.exp(-(J - J_min)))) - J_min
    closed = -c + 0.5 * h @ np.linalg.solve(H, h) + 0.5 * N * np.log(2 * np.pi) - 0.5 * np.linalg.slogdet(H)[1]
    return float(quadrature), float(closed)


def posterior_partition_effect(goals, truth, x0, horizon=20.0, N=100):
    """For eq. (6.17) reaching costs: per distractor ``i``, ``log Z_truth - log Z_i`` (closed form),
    ``J_i^* - J_truth^*`` (the optimal costs) and how much dropping ``Z_truth / Z_i`` changes the observer's
    posterior ``P(truth | u)`` at the truth's own optimum. A list of dicts."""
    dt = horizon / N
    dyn = single_integrator(len(x0), dt)
    costs = [reaching_cost(g, dt) for g in goals]
    plain = solve(dyn, costs[truth], x0, N)
    stars = [c.value(s.xs, s.us) for c, s in ((c, solve(dyn, c, x0, N)) for c in costs)]
    rows = []
    for i, cost in enumerate(costs):
        if i == truth:
            continue
        log_z = [_log_z(dyn, c, x0, N) for c in (costs[truth], cost)]
        j1, j0 = costs[truth].value(plain.xs, plain.us), cost.value(plain.xs, plain.us)
        exact = 1.0 / (1.0 + np.exp(-j0 - log_z[1] + j1 + log_z[0]))
        dropped = 1.0 / (1.0 + np.exp(j1 - j0))
        rows.append({"distractor": i, "log Z_truth - log Z_i": log_z[0] - log_z[1],
                     "J_i* - J_truth*": stars[i] - stars[truth], "posterior change": abs(exact - dropped)})
    return rows


def _log_z(dynamics, cost, x0, N):
    H, h, c = lifted_cost(dynamics, cost, x0, N)
    return float(-c + 0.5 * h @ np.linalg.solve(H, h) + 0.5 * H.shape[0] * np.log(2 * np.pi)
                 - 0.5 * np.linalg.slogdet(H)[1])


def prior_sensitivity(start, goals, goal_index, priors, **options):
    """Dragan and Srinivasa's legible path for each prior ``P(G_R)`` in ``priors`` (the rest shared equally by
    the other goals): the largest distance between any two of the paths, relative to the goal's distance."""
    goals = np.asarray(goals, float)
    paths = []
    for p in priors:
        prior = np.full(len(goals), (1 - p) / (len(goals) - 1))
        prior[goal_index] = p
        paths.append(optimise_legibility(start, goals, goal_index, prior=prior, **options).xs)
    spread = max(np.abs(a - b).max() for a in paths for b in paths)
    return float(spread / np.linalg.norm(goals[goal_index] - np.asarray(start, float))), paths
