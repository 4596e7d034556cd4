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


def receding_horizon_seconds(N=100, repeats=5, schedule=(0.25, 4.0)):
    """Time of a whole receding-horizon run replanning at every step (N replans,
    :func:`mutual.motion.legible.objective.receding_horizon`) on the reference problem, whose
    hypotheses share their quadratic part: every replan's gains follow from the two hypotheses' own."""
    dyn, J1, J0 = _reference(N)
    alpha = linear_alpha_schedule(*schedule)
    return interleaved_best_times({"rh": lambda: receding_horizon(dyn, J1, J0, np.zeros(2), N, alpha)}, repeats)["rh"]
