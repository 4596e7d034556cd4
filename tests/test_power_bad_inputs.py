"""Bad inputs to the replication planner (issues 13 and 16): every public function of the power
modules raises a ValueError naming the argument and the reason."""

import matplotlib
import numpy as np
import pandas as pd
import pytest

from mutual.study import cohort_power as cp
from mutual.study import power as pw
from mutual.study import power_plots
from mutual.study import power_summary as ps
from mutual.study import rm_batch as rb
from mutual.study import sweep

matplotlib.use("Agg")
GOOD = dict(f=0.3, rho=0.5)
TABLE = pd.DataFrame({"n": [6], "test": ["anova_gg"], "power": [0.5], "ci_low": [0.4], "ci_high": [0.6]})


def _enter(manager):
    return manager.__enter__()


def _axes():
    from matplotlib.figure import Figure
    return Figure().add_subplot()


CASES = [
    (pw.rm_anova_power, (1, 3), GOOD, "n must be an integer >= 2"),
    (pw.rm_anova_power, (10, 1), GOOD, "m must be an integer >= 2"),
    (pw.rm_anova_power, (10.5, 3), GOOD, "n must be an integer"),
    (pw.rm_anova_power, (True, 3), GOOD, "n must be an integer"),
    (pw.rm_anova_power, (10, 3), {}, "exactly one of f"),
    (pw.rm_anova_power, (10, 3), dict(f=0.3, rho=0.5, partial_eta_squared=0.1), "exactly one of f"),
    (pw.rm_anova_power, (10, 3), dict(f=-0.1, rho=0.5), "f must be a non-negative"),
    (pw.rm_anova_power, (10, 3), dict(f=np.nan, rho=0.5), "f must be a non-negative"),
    (pw.rm_anova_power, (10, 3), dict(f=0.3), "rho (correlation"),
    (pw.rm_anova_power, (10, 3), dict(f=0.3, rho=1.0), "rho (correlation"),
    (pw.rm_anova_power, (10, 3), dict(partial_eta_squared=0.2, rho=0.5), "rho must not be given"),
    (pw.rm_anova_power, (10, 3), dict(partial_eta_squared=1.0), "partial_eta_squared must lie in [0, 1)"),
    (pw.rm_anova_power, (10, 3), dict(partial_eta_squared=-0.1), "partial_eta_squared must lie in [0, 1)"),
    (pw.rm_anova_power, (10, 3), dict(GOOD, epsilon=0.3), "epsilon must lie in [1/(m-1), 1]"),
    (pw.rm_anova_power, (10, 3), dict(GOOD, epsilon=1.2), "epsilon must lie in [1/(m-1), 1]"),
    (pw.rm_anova_power, (10, 3), dict(GOOD, alpha=0.0), "alpha must lie strictly between 0 and 1"),
    (pw.rm_anova_power, (10, 3), dict(GOOD, alpha=1.5), "alpha must lie strictly between 0 and 1"),
    (pw.rm_anova_sample_size, (0.8, 3), dict(f=0.0, rho=0.5), "the effect size is zero"),
    (pw.rm_anova_sample_size, (0.01, 3), GOOD, "power must exceed alpha"),
    (pw.rm_anova_sample_size, (1.0, 3), GOOD, "power must lie strictly between 0 and 1"),
    (pw.rm_anova_sample_size, (0.99, 3), dict(f=0.01, rho=0.0, n_max=50), "even n_max=50 subjects"),
    (pw.effect_size_from_f, (-1.0, 2, 20), {}, "F must be a non-negative number"),
    (pw.effect_size_from_f, (8.72, 2, 21), {}, "not a one-way repeated-measures design"),
    (pw.effect_size_from_f, (8.72, 2, 2), {}, "df2 must exceed 2"),
    (pw.effect_size_from_f, (8.72, 0, 20), {}, "df_num must be an integer >= 1"),
    (pw.effect_size_from_f, (8.72, 2, 20), dict(confidence=1.0), "confidence must lie strictly between 0 and 1"),
    (pw.noncentrality_interval, (np.nan, 2, 20), {}, "F must be a non-negative number"),
    (pw.unbiased_noncentrality, (5.0, 2, 2), {}, "df2 must exceed 2"),
    (pw.paired_t_power, (np.inf, 10), {}, "dz must be a finite number"),
    (pw.paired_t_power, (0.5, 10), dict(comparisons=0), "comparisons must be an integer >= 1"),
    (pw.paired_t_power, (0.5, 1), {}, "n must be an integer >= 2"),
    (pw.tukey_rm_power, (0.5, 10, 1), {}, "m must be an integer >= 2"),
    (pw.contrast_sample_size, (0.5, 0.8), dict(test="scheffe"), "test must be one of"),
    (pw.contrast_sample_size, (0.0, 0.8), {}, "does not reach power 0.8"),
    (pw.dz_from_summary, (1.0, 2.0, 0.0), {}, "mse must be a positive number"),
    (pw.wilson_interval, (5, 3), {}, "0 <= successes <= trials"),
    (pw.wilson_interval, (0, 0), {}, "trials >= 1"),
    (pw.recommended_n, ([1, 2], [0.5]), dict(target=0.8), "equally long"),
    (pw.replication_plan, (8.72, 2, 21), {}, "not a one-way repeated-measures design"),
    (rb.rm_analyses, (np.zeros((2, 1, 3)),), {}, "y must have shape (R, n >= 2, m >= 2)"),
    (rb.rm_analyses, (np.full((1, 4, 3), np.nan),), {}, "finite numbers"),
    (rb.compound_symmetry, (3, -0.6), {}, "rho must lie in (-1/(m-1), 1)"),
    (rb.simulate_gaussian_rm, (np.zeros(3), np.eye(2), 5, 10), {}, "symmetric (3, 3) matrix"),
    (rb.simulate_gaussian_rm, (np.zeros(3), -np.eye(3), 5, 10), {}, "positive semi-definite"),
    (rb.simulate_gaussian_rm, (np.zeros(3), np.eye(3), 1, 10), {}, "n must be an integer >= 2"),
    (rb.simulate_gaussian_rm, (np.zeros(3), np.eye(3), 5, 0), {}, "reps >= 1"),
    (cp.CohortSetting, (), dict(mix="random"), "mix must be one of"),
    (cp.CohortSetting, (), dict(noise_scale=0.0), "noise_scale must be a positive number"),
    (cp.CohortSetting, (), dict(n_scenes=1), "n_scenes must be an integer >= 2"),
    (cp.CohortSetting, (), dict(trial_seconds=-1.0), "trial_seconds must be a positive number"),
    (cp.CohortTask, (cp.CohortSetting(), -1, 5), {}, "cohort must be an integer >= 0"),
    (cp.CohortTask, (cp.CohortSetting(), 0, 1), {}, "n_max must be an integer >= 2"),
    (cp.CohortTask, (cp.CohortSetting(), 0, 5, -3), {}, "seed must be an integer >= 0"),
    (cp.simulate_cohort, ("task", None, None), {}, "task must be a CohortTask"),
    (cp.simulate_cohort, (cp.CohortTask(cp.CohortSetting(), 0, 5), None, None), {}, "library must be a ValueLibrary"),
    (ps.analysed_outcomes, ([], 5), {}, "cohorts must be a non-empty list"),
    (ps.analysed_outcomes, ([pd.DataFrame()], 1), {}, "n must be an integer >= 2"),
    (ps.power_table, ([], [5]), {}, "cohorts must be a non-empty list"),
    (ps.recommendations, (TABLE,), dict(tests=("nope",)), "no rows for test 'nope'"),
    (sweep.TaskCache, ("",), {}, "version must be a non-empty string"),
    (sweep.scheduler_address, (5,), {}, "scheduler must be an address string"),
    (lambda: _enter(sweep.dask_client(workers=0)), (), {}, "workers must be a positive integer"),
    (lambda: _enter(sweep.dask_client(scheduler="inline")), (), {}, "runs without Dask"),
    (power_plots.power_curve_view, (), dict(n_max=2), "n_max must be at least 3"),
    (lambda: power_plots.plot_simulated_power(_axes(), TABLE, "nope", "x", "k"), (), {}, "no rows for test 'nope'"),
]


@pytest.mark.parametrize("fn, args, kwargs, phrase", CASES,
                         ids=[f"{getattr(c[0], '__name__', 'call')}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, phrase):
    with pytest.raises(ValueError) as err:
        fn(*args, **kwargs)
    assert phrase in str(err.value), f"{err.value!s} does not say {phrase!r}"
