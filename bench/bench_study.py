"""Chapter 5 timings: the whole simulated study (Phase II, fits, Phase III, statistics) with a cached
value-function library, the time per simulated Phase III trial when the study's trials run as one
vectorized batch versus one trial at a time, and the statistics on the study's tidy table.

Full: the 101x101x64 grid, 12 recruits x 40 scenes, 60 s trials (66 trials of 5 robots, 8 obstacles).
Quick: the 41x41x24 grid, 20 s trials. The library is computed (or loaded) before timing.
"""

from mutual.study import stats as st
from mutual.study import cohort, teaming
from mutual.constraints.complexity import best_time
from mutual.study.design import TREATMENTS


def _statistics(trials):
    fp = trials[trials.measure == "false_positives"]
    anova = st.rm_anova(fp, "value", "participant", "treatment", aggregate="mean", levels=TREATMENTS)
    return st.tukey_rm(anova), st.paired_t_holm(anova.cells)


def run(quick=False):
    library, conservative = cohort.study_value_functions(quick=quick)
    config = teaming.TeamingConfig(duration=20.0 if quick else 60.0)
    repeats = 1 if quick else 2
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
    t_serial = best_time(lambda: [teaming.simulate_teaming(teams[i:i + 1], sups[i:i + 1], versions[i:i + 1], config, seed=i)
                                  for i in range(k)], repeats) / k
    t_stats = best_time(lambda: _statistics(study.trials), 5 if quick else 20)
    grid = "quick 41x41x24" if quick else "full 101x101x64"
    size = (f"{len(people)} recruits ({int((~people.excluded).sum())} analysed), {n} trials of "
            f"{config.duration:g} s, dt={config.dt:g}, {config.n_robots} robots, {config.n_obstacles} obstacles")
    return [
        {"benchmark": "simulated user study (ch. 5), cached library", "case": f"{grid}; {size}",
         "seconds": t_study, "baseline": "", "baseline_seconds": None,
         "target": "< 120 s on 2 cores", "met": bool(t_study < 120)},
        {"benchmark": "Phase III time per simulated trial", "case": f"{grid}; {n} trials in one vectorized batch",
         "seconds": t_batch, "baseline": "the same trials one at a time (6 of them)", "baseline_seconds": t_serial,
         "target": "batched faster than one at a time", "met": bool(t_batch < t_serial)},
        {"benchmark": "study statistics (RM-ANOVA, RM Tukey, paired t + Holm)", "case": f"{n} trials x 5 measures",
         "seconds": t_stats, "baseline": "", "baseline_seconds": None, "target": "", "met": None},
    ]
