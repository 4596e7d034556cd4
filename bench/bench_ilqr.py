"""iLQR (chapter 7) against scipy L-BFGS single shooting on the Dubins problem of Fig. 7.2, and the
legible objective's iteration count against the plain ones.

Both solvers use the same jit-compiled objective (L-BFGS also its autodiff gradient), start from
rest, and are timed warm (compilation excluded), best of a few repeats, side by side; each row
gives both final costs.
"""

import time

import numpy as np

from mutual.motion import evident_safety as es
from mutual.motion.legibility import single_integrator
from mutual.motion.legibility import solve as solve_riccati

SPEEDUP_TARGET = 10.0
SAME_ORDER = 3.0  # "same order of iterations": the legible count within 3x the plain ones


def _best_time(fn, repeats):
    best, out = np.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def run(quick=False):
    repeats = 2 if quick else 5
    rows = []
    task, w0, w1 = es.figure_scenario("7.2", steps=100)
    weights = es.hypothesis_set(w0, w1)
    iterations, seconds = {}, {}
    for name, w in weights.items():
        es.solve(task, w), es.solve_lbfgs(task, w)  # compile both
        t_ilqr, result = _best_time(lambda: es.solve(task, w), repeats)
        t_lbfgs, (_, cost, res) = _best_time(lambda: es.solve_lbfgs(task, w), repeats)
        equal = abs(cost - result.cost) <= 1e-6 * (1 + abs(result.cost))
        iterations[name], seconds[name] = result.iterations, t_ilqr
        rows.append({
            "benchmark": "ilqr", "case": f"Dubins Fig. 7.2 {name}, N=100: iLQR {result.iterations} it, cost {result.cost:.12g}; "
                                         f"L-BFGS {res.nit} it / {res.nfev} evals, cost {cost:.12g}; "
                                         f"costs equal: {equal}",
            "seconds": t_ilqr, "baseline": "scipy L-BFGS single shooting (same JAX objective + gradient)",
            "baseline_seconds": t_lbfgs, "target": f"iLQR >= {SPEEDUP_TARGET:g}x faster at equal cost",
            "met": bool(equal and t_lbfgs >= SPEEDUP_TARGET * t_ilqr)})
    plain = max(iterations["H0"], iterations["H1"])
    rows.append({
        "benchmark": "ilqr", "case": f"legible vs plain objective, Dubins N=100: iterations legible "
                                     f"{iterations['legible']}, H0 {iterations['H0']}, H1 {iterations['H1']}",
        "seconds": seconds["legible"], "baseline": "iLQR on the plain H1 objective",
        "baseline_seconds": seconds["H1"], "target": f"same order of iterations (legible <= {SAME_ORDER:g}x plain)",
        "met": bool(iterations["legible"] <= SAME_ORDER * plain)})

    task71, v0, v1 = es.figure_scenario("7.1", steps=100)
    legible = es.hypothesis_set(v0, v1)["legible"]
    lq = es.lq_hypothesis_costs(task71, v0, v1)["legible"]
    es.solve(task71, legible)
    t_ilqr, result = _best_time(lambda: es.solve(task71, legible), repeats)
    t_ric, _ = _best_time(lambda: solve_riccati(single_integrator(2, task71.dt), lq, task71.x0, 100), repeats)
    rows.append({
        "benchmark": "ilqr", "case": f"legible Fig. 7.1 (x' = u, LQ), N=100: iLQR {result.iterations} step",
        "seconds": t_ilqr, "baseline": "chapter 6 Riccati solver (numpy)", "baseline_seconds": t_ric,
        "target": "", "met": None})
    return rows


if __name__ == "__main__":
    for row in run(quick=True):
        print(row)
