"""The study statistics' repeated-measures ANOVA (chapter 5, section 5.3.1) against pingouin and
statsmodels, on the data ``make bench`` times them on (bench/bench_study.py): the simulated study's
false positives, averaged over each participant's trials per safe set.

``pingouin.rm_anova(correction=True)`` gives F, p, the Greenhouse-Geisser epsilon and the corrected
p in one call, as :func:`mutual.study.stats.rm_anova` does; statsmodels' ``AnovaRM`` gives F and p
only. All three start from the same long table (the filter to the false positives is timed for
each), and each is timed as the median of many interleaved calls after a warm-up.
"""

import sys
from pathlib import Path

import numpy as np
import pingouin
from statsmodels.stats.anova import AnovaRM

from mutual.study import cohort, teaming
from mutual.study import stats as st
from mutual.study.design import TREATMENTS

sys.path.insert(0, str(Path(__file__).parent))
from peer_timing import interleaved  # noqa: E402

RTOL = 1e-9


def ours(trials):
    return st.rm_anova(trials, "false_positives", "treatment", "participant", aggregate="mean", levels=TREATMENTS)


def _false_positives(trials):
    return trials[trials.measure == "false_positives"]


def with_pingouin(trials):
    return pingouin.rm_anova(_false_positives(trials), dv="value", within="treatment", subject="participant",
                             correction=True)


def with_statsmodels(trials):
    return AnovaRM(_false_positives(trials), "value", "participant", within=["treatment"],
                   aggregate_func="mean").fit().anova_table


def _column(table, *names):
    """The first of ``names`` that pingouin's table has (its column names changed between releases)."""
    for name in names:
        if name in table.columns:
            return float(table[name].iloc[0])
    raise KeyError(f"none of {names} in pingouin's table {list(table.columns)}")


def run(quick=False):
    library, conservative = cohort.study_value_functions(quick=quick)
    study = cohort.simulate_study(library, conservative, config=teaming.TeamingConfig(duration=20.0 if quick else 60.0),
                                  seed=0)
    trials = study.trials
    (t_ours, t_pg, t_sm), (a, pg, sm) = interleaved(
        [lambda: ours(trials), lambda: with_pingouin(trials), lambda: with_statsmodels(trials)], 20 if quick else 200)
    theirs = {"F": _column(pg, "F"), "p": _column(pg, "p_unc", "p-unc"), "p_GG": _column(pg, "p_GG_corr", "p-GG-corr"),
              "eps": _column(pg, "eps")}
    mine = {"F": a.F, "p": a.p, "p_GG": a.p_gg, "eps": a.eps}
    gaps = {k: abs(mine[k] - theirs[k]) / abs(theirs[k]) for k in mine}
    sm_row = sm.iloc[0]
    agree_sm = bool(np.isclose(a.F, sm_row["F Value"], rtol=RTOL) and np.isclose(a.p, sm_row["Pr > F"], rtol=RTOL))
    agree = bool(max(gaps.values()) <= RTOL)
    fp = _false_positives(trials)
    case = (f"one-way RM-ANOVA with the Greenhouse-Geisser correction: false positives of {fp.participant.nunique()} "
            f"participants x {len(TREATMENTS)} safe sets ({len(fp)} trials, averaged per cell); "
            f"{'quick' if quick else 'full'} simulated study, seed 0")
    values = ", ".join(f"{k} {mine[k]:.10g} / {theirs[k]:.10g} (rel. {gaps[k]:.0e})" for k in mine)
    return [{
        "benchmark": "peers: pingouin", "case": case, "seconds": t_ours["median"],
        "baseline": f"pingouin {pingouin.__version__} rm_anova(correction=True)",
        "baseline_seconds": t_pg["median"], "compile_seconds": None,
        "agree": (f"{agree}: ours / pingouin {values}; statsmodels AnovaRM(aggregate_func='mean') (F and p only, "
                  f"no correction): {t_sm['median'] * 1e3:.3g} ms, F and p equal to rtol {RTOL:g}: {agree_sm}; "
                  f"medians of {t_ours['runs']} interleaved calls"),
        "target": f"agrees with pingouin (F, p, p_GG, eps to rtol {RTOL:g})", "met": agree and agree_sm}]


if __name__ == "__main__":
    for row in run(quick=True):
        print(row)
