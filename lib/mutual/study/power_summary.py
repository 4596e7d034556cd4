"""Power from SIMULATED cohorts (:mod:`.cohort_power`): the study notebook's analysis of every cohort
prefix (RM-ANOVA with the Greenhouse-Geisser correction, RM Tukey, paired t with Holm; Sec. 5.3.1),
vectorized over cohorts by :mod:`.rm_batch`, the Monte Carlo power with Wilson intervals, the
recommended sample sizes, and the effect size the simulated population implies.
"""

import numpy as np
import pandas as pd

from .cohort_power import FP_COLUMNS
from .design import TREATMENTS
from .power import recommended_n, wilson_interval
from .rm_batch import level_pairs, rm_analyses


def analysed_outcomes(cohorts, n):
    """``(C, n, 3)`` false positives of the first ``n`` analysed participants of each cohort table."""
    if not isinstance(cohorts, (list, tuple)) or not cohorts or not all(isinstance(t, pd.DataFrame) for t in cohorts):
        raise ValueError("cohorts must be a non-empty list of tables from mutual.study.cohort_power.simulate_cohort")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"n must be an integer >= 2, got {n!r}")
    out = []
    for table in cohorts:
        kept = table[~table["excluded"]]
        if len(kept) < n:
            raise ValueError(f"cohort {int(table['cohort'].iloc[0])} has {len(kept)} analysed participants, fewer than {n}")
        out.append(kept[list(FP_COLUMNS)].to_numpy(dtype=float)[:n])
    return np.stack(out)


def power_table(cohorts, n_values, alpha=0.05, confidence=0.95):
    """Power of each test at each ``n`` over the simulated ``cohorts`` (tables of :func:`mutual.study.cohort_power.simulate_cohort`
    of one setting), with Wilson intervals: one row per (n, test). Tests: ``anova_gg`` (the omnibus
    RM-ANOVA, Greenhouse-Geisser corrected), ``anova`` (uncorrected), ``tukey <A>-<B>`` and
    ``holm <A>-<B>`` per pair. A cohort whose statistic is undefined (no error variance) counts
    as not significant; ``undefined`` counts them."""
    names = [f"{TREATMENTS[i]}-{TREATMENTS[j]}" for i, j in level_pairs(len(TREATMENTS))]
    rows = []
    for n in n_values:
        res = rm_analyses(analysed_outcomes(cohorts, n))
        tests = {"anova_gg": res.p_gg < alpha, "anova": res.p < alpha}
        tukey, holm = res.tukey_reject(alpha), res.p_holm < alpha
        for k, name in enumerate(names):
            tests[f"tukey {name}"], tests[f"holm {name}"] = tukey[:, k], holm[:, k]
        undefined = int(np.isnan(res.F).sum())
        for test, reject in tests.items():
            hits = int(np.sum(reject))
            lo, hi = wilson_interval(hits, len(reject), confidence)
            rows.append({"n": int(n), "test": test, "cohorts": len(reject), "rejections": hits,
                         "power": hits / len(reject), "ci_low": float(lo), "ci_high": float(hi),
                         "undefined": undefined})
    return pd.DataFrame(rows)


def implied_effect(cohorts, n=None):
    """The population effect the simulation implies, from the pooled analysed participants (the
    first ``n`` of each cohort; all by default): level ``means`` and covariance ``cov`` of the false
    positives per trial, the error variance ``tr(C cov C) / (m - 1)`` (C centres the levels), the
    partial effect ``f_p^2 = var(means) / error variance`` (so ``lambda = f_p^2 N m``), its
    ``eta2p``, the Greenhouse-Geisser ``epsilon`` of ``cov``, the mean correlation ``rho`` and the
    standardized paired difference ``dz`` of each pair (:func:`mutual.study.rm_batch.level_pairs`)."""
    y = np.concatenate([t[~t["excluded"]][list(FP_COLUMNS)].to_numpy(dtype=float)[:n] for t in cohorts])
    m = y.shape[1]
    means, cov = y.mean(axis=0), np.cov(y, rowvar=False)
    c = np.eye(m) - 1.0 / m
    dc = c @ cov @ c
    err = np.trace(dc) / (m - 1)
    fp2 = float(np.mean((means - means.mean()) ** 2) / err)
    sd = np.sqrt(np.diag(cov))
    corr = cov / np.outer(sd, sd)
    dz = {f"{TREATMENTS[i]}-{TREATMENTS[j]}": float((means[i] - means[j]) / np.sqrt(cov[i, i] + cov[j, j] - 2 * cov[i, j]))
          for i, j in level_pairs(m)}
    return {"participants": len(y), "means": dict(zip(TREATMENTS, means.tolist())), "cov": cov, "error_variance": float(err),
            "f_partial": float(np.sqrt(fp2)), "eta2p": fp2 / (1 + fp2),
            "epsilon": float(np.trace(dc) ** 2 / ((m - 1) * np.sum(dc ** 2))),
            "rho": float(corr[np.triu_indices(m, 1)].mean()), "dz": dz}


KEY_TESTS = ("anova_gg", "tukey Standard-Learned", "holm Standard-Learned")


def recommendations(table, targets=(0.8, 0.9), tests=KEY_TESTS):
    """Recommended N per test and target power from a :func:`power_table`: ``n`` where the estimated
    power reaches the target and stays there (:func:`mutual.study.power.recommended_n`), and
    ``n_conservative`` where the lower end of its Wilson interval does; None beyond the largest N.
    ``at_smallest_n``: the target is met already at the smallest N simulated (the answer is "at most n")."""
    rows = []
    for test in tests:
        sub = table[table["test"] == test]
        if sub.empty:
            raise ValueError(f"the table has no rows for test {test!r}")
        for t in targets:
            n = recommended_n(sub["n"], sub["power"], t)
            rows.append({"test": test, "target": t, "n": n, "n_conservative": recommended_n(sub["n"], sub["ci_low"], t),
                         "at_smallest_n": n is not None and n == int(sub["n"].min()), "largest n": int(sub["n"].max())})
    return pd.DataFrame(rows)
