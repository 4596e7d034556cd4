"""Analytic power of the replication planner (issue 16) against independent truth: values G*Power
published for its "ANOVA: repeated measures, within factors" test, the pwr R package's paired
t-test, exact identities (F(1, n-1) = t^2), and simulation of noncentral F statistics."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from mutual.study import power as pw
from mutual.study import stats as st
from mutual.study.design import TREATMENTS

# G*Power 3.1 outputs for "ANOVA: repeated measures, within factors" (1 group), as published in the
# test suite of pingouin (R. Vallat, JOSS 2018), tests/test_power.py::test_power_rm_anova, whose
# docstring says "Values are compared to GPower". pingouin passes eta^2 = f^2 / (1 + f^2): its
# eta = 0.20 is G*Power's f = 0.5 and its eta = 0.0588 G*Power's default f = 0.25.
GPOWER_POWER = [  # f, m, n, epsilon, rho, power
    (0.5, 4, 20, 1.0, 0.5, 0.9998070),
    (0.5, 3, 20, 0.9, 0.5, 0.9968277),
    (0.25, 3, 10, 1.0, 0.7, 0.5271828),
    (0.25, 2, 18, 1.0, 0.6, 0.6089353),
    (0.25, 3, 10, 1.0, -0.5, 0.13818),
]
GPOWER_SAMPLE_SIZE = [  # f, m, power, rho, epsilon, N (same source)
    (0.5, 3, 0.80, 0.5, 1.0, 9),
    (0.25, 4, 0.80, 0.5, 1.0, 24),
    (0.25, 3, 0.90, 0.8, 1.0, 16),
    (0.25, 3, 0.90, 0.5, 0.9, 39),
    # Cross Validated, "Repeated measures within factors settings for G*Power power calculation",
    # answer 68754: f = .25, alpha = .05, 1 - beta = .95, three measures, r = 0 -> total N = 84
    (0.25, 3, 0.95, 0.0, 1.0, 84),
]


@pytest.mark.parametrize("f, m, n, epsilon, rho, expected", GPOWER_POWER)
def test_power_matches_gpower(f, m, n, epsilon, rho, expected):
    assert pw.rm_anova_power(n, m, f=f, rho=rho, epsilon=epsilon) == pytest.approx(expected, rel=1e-4)


@pytest.mark.parametrize("f, m, target, rho, epsilon, expected", GPOWER_SAMPLE_SIZE)
def test_sample_size_matches_gpower(f, m, target, rho, epsilon, expected):
    n = pw.rm_anova_sample_size(target, m, f=f, rho=rho, epsilon=epsilon)
    assert n == expected
    assert pw.rm_anova_power(n - 1, m, f=f, rho=rho, epsilon=epsilon) < target <= pw.rm_anova_power(n, m, f=f, rho=rho, epsilon=epsilon)


def test_partial_eta_squared_carries_the_correlation():
    """f_p^2 = f^2 / (1 - rho): the same test whichever effect size is given."""
    f, rho = 0.3, 0.6
    fp2 = f * f / (1 - rho)
    assert pw.rm_anova_power(14, 3, partial_eta_squared=fp2 / (1 + fp2)) == pytest.approx(
        pw.rm_anova_power(14, 3, f=f, rho=rho), rel=1e-12)


@pytest.mark.parametrize("dz, n", [(0.5, 20), (0.3, 40), (1.1, 6)])
def test_two_levels_is_the_paired_t_test(dz, n):
    """With m = 2, F(1, n-1) = t^2 and lambda = dz^2 n: f_p^2 = dz^2 / 2."""
    fp2 = dz * dz / 2
    assert pw.rm_anova_power(n, 2, partial_eta_squared=fp2 / (1 + fp2)) == pytest.approx(pw.paired_t_power(dz, n), rel=1e-9)


def test_paired_t_matches_pwr():
    """pwr::pwr.t.test(d = 0.5, n = 20, type = "paired") = 0.5645044; n for 80% = 33.37 (pingouin's tests)."""
    assert pw.paired_t_power(0.5, 20) == pytest.approx(0.5645044, rel=1e-5)
    assert pw.contrast_sample_size(0.5, 0.8, test="paired") == 34


def test_bonferroni_divides_alpha():
    assert pw.paired_t_power(0.6, 15, alpha=0.05, comparisons=3) == pytest.approx(pw.paired_t_power(0.6, 15, alpha=0.05 / 3))
    assert pw.paired_t_power(0.6, 15, comparisons=3) < pw.paired_t_power(0.6, 15)


def test_tukey_power_at_zero_effect_is_familywise_level_per_pair():
    """Under H0 one pair's rejection rate is below alpha (alpha is the familywise rate over m pairs)
    and, for m = 2, Tukey's HSD is the paired-t-on-MSE test: exactly alpha."""
    assert pw.tukey_rm_power(0.0, 12, 2) == pytest.approx(0.05, abs=1e-6)
    assert 0.01 < pw.tukey_rm_power(0.0, 12, 3) < 0.05


def test_tukey_critical_value_matches_the_study_p_value():
    """At the power function's critical q, the study's Tukey p-value equals alpha."""
    n, m = 11, 3
    crit = stats.studentized_range.isf(0.05, m, (m - 1) * (n - 1))
    mse = 2.0
    table = st.tukey_from_summary({"A": crit * np.sqrt(mse / n), "B": 0.0, "C": 0.0}, mse, n)
    assert table.loc[0, "p"] == pytest.approx(0.05, rel=1e-6)


def test_reported_f_effect_sizes():
    """The thesis's F(2, 20) = 8.72 (Sec. 5.3.1): the partial eta squared of a table with that F is
    SS_effect / (SS_effect + SS_error), and the corrections shrink it."""
    rng = np.random.default_rng(4)
    y = rng.normal(size=(11, 3)) + [1.0, 0.2, -0.5]
    long = pd.DataFrame({"s": np.repeat(np.arange(11), 3), "t": np.tile(TREATMENTS, 11), "v": y.ravel()})
    a = st.rm_anova(long, dv="v", within="t", subject="s", levels=TREATMENTS)
    resid = y - y.mean(1, keepdims=True) - y.mean(0) + y.mean()
    ss_eff, ss_err = 11 * np.sum((y.mean(0) - y.mean()) ** 2), np.sum(resid ** 2)
    est = pw.effect_size_from_f(a.F, a.df_num, a.df_den)
    assert est.eta2p == pytest.approx(ss_eff / (ss_eff + ss_err), rel=1e-9)
    thesis = pw.effect_size_from_f(8.72, 2, 20)
    assert (thesis.m, thesis.n) == (3, 11)
    assert thesis.eta2p > thesis.epsilon2p > thesis.omega2p > thesis.eta2p_unbiased > 0
    lo, hi = thesis.eta2p_ci
    assert lo < thesis.eta2p_unbiased < hi and lo < thesis.eta2p < hi
    assert "bias-corrected" in repr(thesis)


def test_unbiased_noncentrality_is_unbiased():
    lam, df1, df2 = 9.0, 2, 20
    draws = stats.ncf.rvs(df1, df2, lam, size=200_000, random_state=np.random.default_rng(1))
    est = pw.unbiased_noncentrality(draws, df1, df2)
    se = est.std() / np.sqrt(len(est))
    assert abs(est.mean() - lam) < 4 * se
    naive = df1 * draws - df1  # the moment estimate ignores E F = df2 / (df2 - 2) under H0: biased up
    assert naive.mean() - lam > 10 * se


def test_noncentrality_interval_covers():
    lam, df1, df2 = 10.0, 2, 20
    draws = stats.ncf.rvs(df1, df2, lam, size=300, random_state=np.random.default_rng(2))
    covered = [lo <= lam <= hi for lo, hi in (pw.noncentrality_interval(F, df1, df2) for F in draws)]
    assert abs(np.mean(covered) - 0.95) < 4 * np.sqrt(0.95 * 0.05 / len(draws))
    lo, hi = pw.noncentrality_interval(0.3, 2, 20)
    assert lo == 0.0 and hi > 0  # an F below its null median: the lower end is 0


def test_replication_plan_orders_the_estimates():
    plan = pw.replication_plan(8.72, 2, 20)
    n80 = plan["N for 80%"].tolist()
    assert n80 == sorted(n80), "smaller effect estimates must need more participants"
    row = plan.set_index("estimate").loc["bias-corrected (unbiased lambda)"]
    assert row["N for 80%"] == pw.rm_anova_sample_size(0.8, 3, partial_eta_squared=row["eta2p"])


def test_dz_from_summary_matches_the_tukey_statistic():
    """q / sqrt(2) of the study's Tukey test equals dz sqrt(n) at the sample values."""
    mse, n = 20.2, 11
    table = st.tukey_from_summary({"Standard": 12.54, "Learned": 7.31, "Conservative": 4.68}, mse, n)
    assert pw.dz_from_summary(12.54, 7.31, mse) * np.sqrt(n) == pytest.approx(table.loc[0, "q"] / np.sqrt(2))


def test_wilson_matches_statsmodels():
    from statsmodels.stats.proportion import proportion_confint
    for k, n in [(0, 10), (3, 10), (57, 60), (60, 60)]:
        assert np.allclose(pw.wilson_interval(k, n), proportion_confint(k, n, method="wilson"))


@pytest.mark.parametrize("power, target, expected", [
    ([0.5, 0.7, 0.85, 0.9], 0.8, 3), ([0.5, 0.82, 0.78, 0.9], 0.8, 4), ([0.9, 0.95, 0.97, 0.99], 0.8, 1),
    ([0.5, 0.6, 0.7, 0.75], 0.8, None)])
def test_recommended_n_waits_for_the_curve_to_settle(power, target, expected):
    n = [1, 2, 3, 4]
    assert pw.recommended_n(n, power, target) == expected


def test_contrast_sample_size_reaches_target():
    for test in ("tukey", "paired", "bonferroni"):
        n = pw.contrast_sample_size(0.7, 0.8, test=test)
        fn = {"tukey": lambda k: pw.tukey_rm_power(0.7, k, 3), "paired": lambda k: pw.paired_t_power(0.7, k),
              "bonferroni": lambda k: pw.paired_t_power(0.7, k, comparisons=3)}[test]
        assert fn(n - 1) < 0.8 <= fn(n)
    assert pw.contrast_sample_size(0.7, 0.8, test="paired") < pw.contrast_sample_size(0.7, 0.8, test="tukey") \
        < pw.contrast_sample_size(0.7, 0.8, test="bonferroni")
