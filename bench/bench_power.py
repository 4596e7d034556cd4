"""Replication power (issue 16): the Dask sweep of SIMULATED cohorts with 1 and 2 workers against the
same cohorts in one process, the machinery's overhead per task, the vectorized cohort analysis
against the study's own statistics, and the Explore view of notebook 08.

Full: cohorts of 11 analysed participants on the 101x101x64 grid with 60-s trials (the study's
settings); quick: the 41x41x24 grid, 15 scenes, 20-s trials. A cluster's start-up (worker processes
importing the package) is reported as the one-off compile time, not in the sweep's seconds; the
value functions are loaded (or computed) before timing. No cache: every cohort is simulated.
"""

import time

import numpy as np
import pandas as pd

from mutual.constraints.complexity import best_time
from mutual.study import cohort, cohort_power as cp, power_plots, rm_batch, sweep
from mutual.study import stats as st
from mutual.study.design import TREATMENTS


def _sweep(tasks, shared, workers):
    """(seconds of the sweep, start-up seconds of the cluster, results, stats) on ``workers`` local workers."""
    start = time.perf_counter()
    with sweep.dask_client(workers=workers) as client:
        client.wait_for_workers(workers)
        client.run(lambda: __import__("mutual.study.cohort_power"))  # the workers import the package once
        up = time.perf_counter() - start
        results, stats = sweep.run_tasks(cp.simulate_cohort, tasks, shared=shared, client=client, progress=False)
    return stats.seconds, up, results, stats


def _same(a, b):
    return all(x.equals(y) for x, y in zip(a, b)) and len(a) == len(b)


def _study_statistics(y):
    long = pd.DataFrame({"participant": np.repeat(np.arange(y.shape[0]), 3), "treatment": np.tile(TREATMENTS, y.shape[0]),
                         "fp": y.ravel()})
    anova = st.rm_anova(long, dv="fp", within="treatment", subject="participant", levels=TREATMENTS)
    return anova, st.tukey_rm(anova), st.paired_t_holm(anova)


def run(quick=False):
    library, conservative = cohort.study_value_functions(quick=quick)
    setting = cp.CohortSetting(n_scenes=15, trial_seconds=20.0, quick_grid=True) if quick else cp.CohortSetting()
    n_cohorts, n = (4, 11) if quick else (8, 11)
    tasks = [cp.CohortTask(setting, c, n) for c in range(n_cohorts)]
    shared = (library, conservative)

    start = time.perf_counter()
    inline, _ = sweep.run_tasks(cp.simulate_cohort, tasks, shared=shared, scheduler="inline", progress=False)
    t_inline = time.perf_counter() - start
    t1, up1, one, _ = _sweep(tasks, shared, 1)
    t2, up2, two, stats2 = _sweep(tasks, shared, 2)
    identical = _same(inline, one) and _same(inline, two)

    noops = list(range(200))
    with sweep.dask_client(workers=2) as client:
        client.wait_for_workers(2)
        sweep.run_tasks(sweep.noop, noops[:20], params=lambda t: {"t": t}, client=client, progress=False)  # warm
        _, noop_stats = sweep.run_tasks(sweep.noop, noops, params=lambda t: {"t": t}, client=client, progress=False)
    t_noop = noop_stats.seconds / len(noops)

    y = rm_batch.simulate_gaussian_rm(np.array([12.5, 7.3, 4.7]), 20.0 * np.eye(3) + 10.0, 11, 400 if quick else 2000, seed=0)
    t_batch = best_time(lambda: rm_batch.rm_analyses(y).tukey_reject(), 3) / len(y)
    k = 5 if quick else 20
    t_study = best_time(lambda: [_study_statistics(y[i]) for i in range(k)], 1 if quick else 3) / k
    res = rm_batch.rm_analyses(y[:k])
    agree = all(np.isclose(_study_statistics(y[i])[0].p_gg, res.p_gg[i], rtol=1e-9) for i in range(k))

    t_view = best_time(lambda: power_plots.power_curve_view(f=0.4, rho=0.5), 1 if quick else 3)

    grid = "quick 41x41x24 grid, 15 scenes, 20-s trials" if quick else "full 101x101x64 grid, 40 scenes, 60-s trials"
    case = f"{n_cohorts} SIMULATED cohorts of {n} analysed participants, {grid}"
    same = f"{'yes' if identical else 'NO'}: every cohort's table identical (pandas equals) inline, 1 and 2 workers"
    empty = {"baseline": "", "baseline_seconds": None, "compile_seconds": None, "agree": ""}
    return [
        {**empty, "benchmark": "cohort sweep on Dask, LocalCluster with 1 worker", "case": case, "seconds": t1,
         "baseline": "the same cohorts in one process, no Dask", "baseline_seconds": t_inline, "compile_seconds": up1,
         "agree": same, "target": "overhead under 10% of the inline time", "met": bool(t1 < 1.1 * t_inline)},
        {**empty, "benchmark": "cohort sweep on Dask, LocalCluster with 2 workers", "case": case, "seconds": t2,
         "baseline": "the same cohorts in one process, no Dask", "baseline_seconds": t_inline, "compile_seconds": up2,
         "agree": same + f"; {stats2.workers} workers", "target": "faster than 1 worker (2 cores)",
         "met": bool(identical and t2 < t1)},
        {**empty, "benchmark": "sweep machinery overhead per task", "case": "200 no-op tasks, LocalCluster with 2 workers",
         "seconds": t_noop, "target": "under 0.1 s per task (a cohort takes seconds)", "met": bool(t_noop < 0.1)},
        {**empty, "benchmark": "cohort analysis (RM-ANOVA + GG, RM Tukey, paired t + Holm), per cohort",
         "case": f"{len(y)} cohorts of 11 x 3, vectorized (rm_batch.rm_analyses)", "seconds": t_batch,
         "baseline": "mutual.study.stats rm_anova + tukey_rm + paired_t_holm, one cohort at a time",
         "baseline_seconds": t_study, "agree": f"{'yes' if agree else 'NO'}: GG p-values of {k} cohorts, rtol 1e-9",
         "target": "agrees with the study's functions", "met": agree},
        {**empty, "benchmark": "Explore: power_plots.power_curve_view", "case": "N = 2..40, m = 3, with the 80%/90% sample sizes",
         "seconds": t_view, "target": "about 1 s on 2 cores", "met": bool(t_view < 1.5)},
    ]
