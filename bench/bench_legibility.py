"""Chapter 6 timings: legible LQR vs plain LQR (Corollary 6.4.2.1), vs Dragan & Srinivasa's
optimiser reaching its best score, and receding-horizon replanning at every step.

Reference case: x_{k+1} = x_k + dt u_k, dt = 0.01, N = 100, eq. (6.17) with g0 = (-1, 1),
g1 = (1, 1), start at the origin; legible objective (1 + alpha) J1 - J0 with alpha = 1.
"""

import numpy as np

from mutual.motion import dragan as ds
from mutual.motion import legibility as leg
from mutual.constraints.complexity import best_time

DT, N = 0.01, 100
G0, G1 = np.array([-1.0, 1.0]), np.array([1.0, 1.0])
X0 = np.zeros(2)


def dragan_iterations_to_best(goals, beta_ratio, rel_tol=1e-4):
    """Iterations the D&S optimiser needs to come within ``rel_tol`` of its converged score while
    inside its trust region (cost <= beta (1 + rel_tol))."""
    full = ds.optimise_legibility(X0, goals, 1, N=N, beta_ratio=beta_ratio, max_iter=5000, tol=1e-12)
    beta = beta_ratio * full.costs[0]
    ok = (full.scores >= full.scores[-1] * (1 - rel_tol)) & (full.costs <= beta * (1 + rel_tol))
    return int(np.argmax(ok)), full


def run(quick=False):
    repeats = 5 if quick else 30
    dyn = leg.single_integrator(2, DT)
    J0, J1 = leg.reaching_cost(G0, DT), leg.reaching_cost(G1, DT)
    t_plain = best_time(lambda: leg.solve(dyn, J1, X0, N), repeats)
    t_legible = best_time(lambda: leg.legible_trajectory(dyn, J1, J0, X0, N, 1.0), repeats)

    goals = np.array([G0, G1])
    iters, _ = dragan_iterations_to_best(goals, beta_ratio=1.5)
    t_dragan = best_time(lambda: ds.optimise_legibility(X0, goals, 1, N=N, beta_ratio=1.5, max_iter=iters, tol=0.0),
                         repeats)

    schedule = leg.linear_alpha_schedule(0.25, 4.0)
    t_rh = best_time(lambda: leg.receding_horizon(dyn, J1, J0, X0, N, schedule, every=1), max(2, repeats // 10))

    return [
        {"benchmark": "legible LQR (Cor. 6.4.2.1)", "case": f"x'=u, N={N}, alpha=1", "seconds": t_legible,
         "baseline": "plain LQR of J1 (same solver)", "baseline_seconds": t_plain,
         "target": "legible <= 2x plain (ratio >= 0.5)", "met": bool(t_legible <= 2 * t_plain)},
        {"benchmark": "legible LQR vs Dragan-Srinivasa",
         "case": f"2 goals, N={N}, D&S beta=1.5 C*, {iters} iters to best",
         "seconds": t_legible, "baseline": "D&S functional gradient to its best score", "baseline_seconds": t_dragan,
         "target": "ours >= 100x faster", "met": bool(t_dragan >= 100 * t_legible)},
        {"benchmark": "receding-horizon legibility (eq. 6.16)", "case": f"replan every step, N={N}", "seconds": t_rh,
         "baseline": "", "baseline_seconds": None, "target": "< 0.25 s (well under 1 s)", "met": bool(t_rh < 0.25)},
    ]
