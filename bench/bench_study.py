"""Chapter 5 timings: the whole simulated study (Phase II, fits, Phase III, statistics) with a cached
value-function library, the time per simulated Phase III trial when the study's trials run as one
vectorized batch versus one trial at a time, the study statistics against statsmodels, and the
Explore views of notebook 04.

Full: the 101x101x64 grid, 12 recruits x 40 scenes, 60 s trials (66 trials of 5 robots, 8 obstacles).
Quick: the 41x41x24 grid, 20 s trials. The library is computed (or loaded) before timing.
"""

import numpy as np
from statsmodels.stats.anova import AnovaRM
from statsmodels.stats.multitest import multipletests

from mutual.constraints.complexity import best_time
from mutual.study import cohort, explore, teaming
from mutual.study import stats as st
from mutual.study.design import TREATMENTS


def _statistics(trials):
    anova = st.rm_anova(trials, "false_positives", "treatment", "participant", aggregate="mean", levels=TREATMENTS)
    return anova, st.tukey_rm(anova), st.paired_t_holm(anova)


def _statsmodels(trials):
    """The practitioner's route: statsmodels AnovaRM (with aggregate_func) and Holm from multipletests."""
    fp = trials[trials.measure == "false_positives"]
    table = AnovaRM(fp, "value", "participant", within=["treatment"], aggregate_func="mean").fit().anova_table
    wide = fp.groupby(["participant", "treatment"])["value"].mean().unstack()
    from scipy import stats
    p = [stats.ttest_rel(wide[a], wide[b]).pvalue for a, b in (("Standard", "Learned"), ("Standard", "Conservative"),
                                                                ("Learned", "Conservative"))]
    return table, multipletests(p, method="holm")[1]


def run(quick=False):
    library, conservative = cohort.study_value_functions(quick=quick)
    config = teaming.TeamingConfig(duration=20.0 if quick else 60.0)
    repeats = 1 if quick else 3
    study = None

    def whole():
        nonlocal study
        study = cohort.simulate_study(library, conservative, config=config, seed=0)
        _statistics(study.trials)

    t_study = best_time(whole, repeats)

    # the same trials: one batch vs one at a time (a subset of six for the serial baseline)
    people = study.participants.set_index("participant")
    keep = study.summary
    teams = [teaming.Team(study.standard if t == "Standard" else conservative if t == "Conservative"
                          else study.fits[p].value_fn, study.fits[p].mu if t == "Learned" else 0.0)
             for p, t in zip(keep["participant"], keep["treatment"])]
    sups = [study.supervisors[p] for p in keep["participant"]]
    versions = keep["task_version"].tolist()
    n = len(teams)
    t_batch = best_time(lambda: teaming.simulate_teaming(teams, sups, versions, config, seed=0), repeats) / n
    k = 6
    t_serial = best_time(lambda: [teaming.simulate_teaming(teams[i:i + 1], sups[i:i + 1], versions[i:i + 1], config,
                                                           seed=i) for i in range(k)], repeats) / k

    ours, reference = _statistics(study.trials), _statsmodels(study.trials)
    row = reference[0].iloc[0]
    agree = bool(np.isclose(ours[0].F, row["F Value"], rtol=1e-9) and np.isclose(ours[0].p, row["Pr > F"], rtol=1e-9)
                 and np.allclose(np.sort(ours[2]["p_holm"]), np.sort(reference[1])))
    t_stats = best_time(lambda: _statistics(study.trials), 5 if quick else 20)
    t_reference = best_time(lambda: _statsmodels(study.trials), 3 if quick else 10)

    explore._value_functions(True)                    # load the quick grid once, as the notebook does
    t_cohort_view = best_time(lambda: explore.cohort_view(), 1 if quick else 3)
    t_misalignment_view = best_time(lambda: explore.misalignment_view(k=1.0), 1 if quick else 3)

    grid = "quick 41x41x24" if quick else "full 101x101x64"
    size = (f"{len(people)} recruits ({int((~people.excluded).sum())} analysed), {n} trials of "
            f"{config.duration:g} s, dt={config.dt:g}, {config.n_robots} robots, {config.n_obstacles} obstacles")
    empty = {"baseline": "", "baseline_seconds": None, "compile_seconds": None, "agree": ""}
    return [
        {**empty, "benchmark": "simulated user study (ch. 5), cached library", "case": f"{grid}; {size}",
         "seconds": t_study, "target": "< 120 s on 2 cores", "met": bool(t_study < 120)},
        {**empty, "benchmark": "Phase III time per simulated trial", "case": f"{grid}; {n} trials in one vectorized batch",
         "seconds": t_batch, "baseline": "the same trials one at a time (6 of them)", "baseline_seconds": t_serial,
         "agree": "same simulator, same per-trial model (the batch shares one random stream)",
         "target": "batched faster than one at a time", "met": bool(t_batch < t_serial)},
        {**empty, "benchmark": "study statistics (RM-ANOVA + GG, RM Tukey, paired t + Holm)",
         "case": f"{n} trials, false positives of {int((~people.excluded).sum())} participants x 3 safe sets",
         "seconds": t_stats, "baseline": "statsmodels AnovaRM(aggregate_func='mean') + paired t + multipletests(holm)",
         "baseline_seconds": t_reference,
         "agree": f"{'yes' if agree else 'NO'}: F, p (rtol 1e-9) and the Holm p-values compared",
         "target": "agrees with statsmodels", "met": agree},
        {**empty, "benchmark": "Explore: explore.cohort_view (a new simulated cohort + ANOVA + figure)",
         "case": "quick grid, 12 recruits, 15 s trials, 40 scenes", "seconds": t_cohort_view,
         "target": "about 1 s on 2 cores", "met": bool(t_cohort_view < 1.5)},
        {**empty, "benchmark": "Explore: explore.misalignment_view (Fig. 5.1 live)",
         "case": "quick grid, 40 robots x 2 teams", "seconds": t_misalignment_view,
         "target": "about 1 s on 2 cores", "met": bool(t_misalignment_view < 1.5)},
    ]
