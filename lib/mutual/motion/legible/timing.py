"""Measured costs of chapter 6's claims about computation (Corollary 6.4.2.1, replanning online).

Wall-clock times vary by machine and load: each function times its candidates interleaved
(one call of each per round) and keeps the best of the rounds, which is the least disturbed
by other processes. Ratios of two computations (Corollary 6.4.2.1) use the CPU time of this
process (``time.process_time``), which other processes on a busy machine disturb far less;
latencies (a replan against a control period) use wall-clock time.
"""

import time

import numpy as np
import pandas as pd

from .objective import legible_trajectory, linear_alpha_schedule, receding_horizon
from .problem import reaching_cost, single_integrator, solve

G0, G1 = np.array([-1.0, 1.0]), np.array([1.0, 1.0])


def interleaved_best_times(fns, repeats=5, clock="wall", calls=1):
    """Best time (s) per call of each callable in ``fns`` (a dict), called in turn ``repeats`` times;
    each timing covers ``calls`` consecutive calls. ``clock``: ``"wall"`` or ``"process"`` (CPU time)."""
    if not isinstance(repeats, (int, np.integer)) or repeats < 1:
        raise ValueError(f"repeats must be a positive integer, got {repeats!r}")
    if clock not in ("wall", "process"):
        raise ValueError(f"clock must be 'wall' or 'process', got {clock!r}")
    now = time.perf_counter if clock == "wall" else time.process_time
    best = {name: np.inf for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            start = now()
            for _ in range(calls):
                fn()
            best[name] = min(best[name], (now() - start) / calls)
    return best


def _reference(N):
    dt = 1.0 / N
    return single_integrator(2, dt), reaching_cost(G1, dt), reaching_cost(G0, dt)


def corollary_time_ratios(sizes=(100, 400, 1600), alpha=1.0, repeats=5, backend="numpy"):
    """Corollary 6.4.2.1: time of the legible solve (forming ``(1 + alpha) J1 - J0`` and solving it)
    against the plain solve of ``J1`` alone, on the reference problem (x' = u, eq. (6.17), goals
    (-1, 1) and (1, 1), T = 1) for each horizon in ``sizes``: CPU seconds per call, best of ``repeats``
    interleaved rounds of enough calls to last about 20 ms. A DataFrame with the times, their ratio
    and, in ``attrs``, the fitted growth exponents ``t ~ N^p`` of both."""
    rows = []
    x0 = np.zeros(2)
    for N in sizes:
        dyn, J1, J0 = _reference(N)
        start = time.perf_counter()
        solve(dyn, J1, x0, N, backend=backend)     # warm up (and compile, for "jax"), outside the timing
        calls = max(1, int(0.02 / max(time.perf_counter() - start, 1e-6)))
        best = interleaved_best_times({
            "plain": lambda: solve(dyn, J1, x0, N, backend=backend),
            "legible": lambda: legible_trajectory(dyn, J1, J0, x0, N, alpha, backend=backend)}, repeats,
            clock="process", calls=calls)
        rows.append({"N": N, "plain LQR (s)": best["plain"], "legible LQR (s)": best["legible"],
                     "ratio legible / plain": best["legible"] / best["plain"]})
    table = pd.DataFrame(rows)
    if len(sizes) > 1:
        logN = np.log(table["N"])
        table.attrs["exponent plain"] = float(np.polyfit(logN, np.log(table["plain LQR (s)"]), 1)[0])
        table.attrs["exponent legible"] = float(np.polyfit(logN, np.log(table["legible LQR (s)"]), 1)[0])
    return table


def _stage_dict(dynamics, cost, N):
    dyn, c = dynamics.stages(0, N), cost.stages(0, N)
    n, m = dyn.n, dyn.m
    return {"A": np.broadcast_to(dyn.A, (N, n, n)), "B": np.broadcast_to(dyn.B, (N, n, m)),
            "Q": np.broadcast_to(c.Q, (N, n, n)), "R": np.broadcast_to(c.R, (N, m, m)),
            "q": np.broadcast_to(c.q, (N, n)), "r": np.broadcast_to(c.r, (N, m)),
            "M": np.broadcast_to(np.zeros((n, m)), (N, n, m)), "c": np.broadcast_to(np.zeros(n), (N, n))}, c


def corollary_operation_counts(sizes=(100, 400, 1600), alpha=1.0):
    """Corollary 6.4.2.1 as a count instead of a timing: XLA's floating-point operations of the compiled
    plain solve of ``J1`` and of the compiled legible solve that forms ``(1 + alpha) J1 - J0`` from both
    hypotheses' stage arrays and then runs the same recursion (:func:`.lqr_compiled.solve_flops`), on the
    reference problem for each horizon in ``sizes``. A DataFrame with both counts and their ratio;
    deterministic on a given machine and JAX version."""
    from .lqr_compiled import solve_flops

    rows = []
    for N in sizes:
        dyn, J1, J0 = _reference(N)
        s1, c1 = _stage_dict(dyn, J1, N)
        s0, c0 = _stage_dict(dyn, J0, N)
        plain = solve_flops(s1, c1.QN, c1.qN, np.zeros(2), N)
        legible = solve_flops(s1, c1.QN, c1.qN, np.zeros(2), N, combine=(1.0 + alpha, 1.0, s0, c0.QN, c0.qN))
        rows.append({"N": N, "plain LQR (flops)": plain, "legible LQR (flops)": legible,
                     "ratio legible / plain": legible / plain})
    return pd.DataFrame(rows)


def replan_seconds(N=100, repeats=20, backend="jax", alpha=1.0):
    """Latency of one replan of eq. (6.16) on the reference problem: the legible LQ solve over the
    whole remaining horizon ``N`` (the longest replan) from a fresh state. Returns
    ``(seconds, compile_seconds)``; the compile time (first call, ``backend="jax"``) is excluded."""
    dyn, J1, J0 = _reference(N)
    x0 = np.array([0.1, -0.2])
    start = time.perf_counter()
    legible_trajectory(dyn, J1, J0, x0, N, alpha, backend=backend)
    first = time.perf_counter() - start
    best = interleaved_best_times({"replan": lambda: legible_trajectory(dyn, J1, J0, x0, N, alpha,
                                                                        backend=backend)}, repeats)["replan"]
    return best, max(first - best, 0.0)


def replan_against_dragan(N=100, n_goals=2, repeats=5):
    """Section 6.5 (line 1255): "whereas the original path planning problem would have been too expensive to
    replan, the streamlined objective ... is tractable enough to replan online". Wall-clock seconds of one
    legible replan over the whole horizon (the compiled Riccati solve of eq. (6.15), x' = u, eq. (6.17),
    compile excluded) against Dragan and Srinivasa's path planner on the same goals
    (:func:`mutual.motion.legible.dragan.optimise_legibility`: functional gradient with a banded solve of
    its metric, from the straight line until an iteration changes the score by less than 1e-9), each the
    best of ``repeats`` interleaved runs, in CPU time of this process (as ``make bench`` measures: on a busy
    machine the wall clock of a compiled call includes waiting for JAX's dispatch thread) and wall-clock time. Goals: ``n_goals`` on a row at height 1, x from -1 to 1, the
    truth the last; both solve their own formulation to convergence. Returns a dict with both
    methods' times on both clocks, the ratios and D&S's iterations."""
    from .dragan import optimise_legibility

    if not isinstance(n_goals, (int, np.integer)) or n_goals < 2:
        raise ValueError(f"n_goals must be an integer >= 2, got {n_goals!r}")
    goals = np.c_[np.linspace(-1.0, 1.0, n_goals), np.ones(n_goals)]
    dt = 1.0 / N
    dyn = single_integrator(2, dt)
    costs = [reaching_cost(g, dt) for g in goals]
    x0 = np.zeros(2)
    legible_trajectory(dyn, costs[-1], costs[:-1], x0, N, 1.0, backend="jax")     # compile
    theirs = optimise_legibility(x0, goals, n_goals - 1, N=N, max_iter=20_000)
    fns = {"ours": lambda: legible_trajectory(dyn, costs[-1], costs[:-1], x0, N, 1.0, backend="jax"),
           "theirs": lambda: optimise_legibility(x0, goals, n_goals - 1, N=N, max_iter=20_000)}
    cpu, wall = interleaved_best_times(fns, repeats, clock="process"), interleaved_best_times(fns, repeats)
    return {"N": N, "goals": n_goals, "CPU s ours": cpu["ours"], "CPU s theirs": cpu["theirs"],
            "ratio (CPU)": cpu["theirs"] / cpu["ours"], "wall s ours": wall["ours"], "wall s theirs": wall["theirs"],
            "ratio (wall)": wall["theirs"] / wall["ours"], "D&S iterations": theirs.iterations}


def receding_horizon_seconds(N=100, repeats=5, schedule=(0.25, 4.0)):
    """Time of a whole receding-horizon run replanning at every step (N replans,
    :func:`mutual.motion.legible.objective.receding_horizon`) on the reference problem, whose
    hypotheses share their quadratic part: every replan's gains follow from the two hypotheses' own."""
    dyn, J1, J0 = _reference(N)
    alpha = linear_alpha_schedule(*schedule)
    return interleaved_best_times({"rh": lambda: receding_horizon(dyn, J1, J0, np.zeros(2), N, alpha)}, repeats)["rh"]
