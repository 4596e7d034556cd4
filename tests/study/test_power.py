"""Analytic power of a replication against independent truth: the values G*Power published for its "ANOVA:
repeated measures, within factors" test, the pwr R package's paired t-test, exact identities
(F(1, n-1) = t^2), simulation of noncentral F statistics and of Gaussian repeated-measures data; power at
zero effect is alpha and the noncentral F is guarded where scipy fails; impossible parameters and bad
inputs refused (tables)."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from mutual.study import power as pw, rm_batch as rb, stats as st
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


@pytest.mark.parametrize("kwargs", [dict(f=0.0, rho=0.5), dict(partial_eta_squared=0.0), dict(f=0.0, rho=-0.4),
                                    dict(f=0.0, rho=0.5, epsilon=0.6)])
@pytest.mark.parametrize("alpha", [0.05, 0.01, 0.2])
def test_power_at_zero_effect_is_alpha(kwargs, alpha):
    assert pw.rm_anova_power(11, 3, alpha=alpha, **kwargs) == pytest.approx(alpha, rel=1e-12)


NONCENTRAL = [  # (x, dfn, dfd, nc): scipy's ncf gives -0.95, NaN or a wrong value at some of these
    (3.49, 2, 20, 0.0), (3.49, 2, 20, 1e-300), (3.49, 0.5, 5, 0.0), (1e6, 2, 20, 0.0),
    (3.49, 2, 20, 1e10), (3.49, 2, 20, 1e11), (5e10, 2, 20, 1e11), (1e300, 2, 20, 1e18), (3.49, 2, 20, 1e20),
    (1e300, 2, 20, 8e300), (0.0, 2, 20, 5.0), (np.inf, 2, 20, 5.0),
]


@pytest.mark.parametrize("x, dfn, dfd, nc", NONCENTRAL)
def test_the_noncentral_f_is_a_probability_and_its_limit(x, dfn, dfd, nc):
    upper = pw.noncentral_f_sf(x, dfn, dfd, nc)
    lower = pw.noncentral_f_sf(x, dfn, dfd, nc, lower=True)
    assert 0 <= upper <= 1 and 0 <= lower <= 1 and upper + lower == pytest.approx(1, abs=1e-12)
    if nc == 0 or nc == 1e-300:
        assert upper == pytest.approx(stats.f.sf(x, dfn, dfd), rel=1e-9, abs=1e-15)
    elif nc >= pw.NC_ASYMPTOTIC and np.isfinite(x) and x > 0:
        # the numerator concentrates at its mean (nc + dfn) / dfn: F' -> that / (chi2_dfd / dfd)
        assert upper == pytest.approx(stats.chi2.cdf(dfd * (nc + dfn) / dfn / x, dfd), abs=1e-6)


def test_the_asymptotic_limit_meets_scipy_where_scipy_still_converges():
    for nc in (1e9, 1e10 * (1 - 1e-12)):
        for x in nc / 2 * np.array([0.5, 0.9, 1.0, 1.1, 2.0]):
            asymptote = stats.chi2.cdf(20 * (nc + 2) / 2 / x, 20)
            assert pw.noncentral_f_sf(x, 2, 20, nc) == pytest.approx(asymptote, abs=1e-7)


def test_power_grows_to_one_at_huge_effects():
    assert pw.rm_anova_power(11, 3, partial_eta_squared=1 - 1e-12) == 1.0
    assert pw.rm_anova_power(100_000, 3, f=1e3, rho=0.5) == 1.0


def test_an_observed_f_of_1e300_has_a_finite_interval():
    lo, hi = pw.noncentrality_interval(1e300, 2, 20)
    assert 0 < lo < hi < np.inf


@pytest.mark.parametrize("F", [0.0, 0.5, 0.99])
def test_sample_sizes_of_no_effect_are_missing_not_nan(F):
    plan = pw.replication_plan(F, 2, 20)
    assert str(plan["N for 80%"].dtype) == "Int64"
    assert plan["N for 80%"].isna().sum() >= 5 and (plan["power at N = 11"] >= 0.05 - 1e-12).all()


def test_gpower_matches_g_power():
    """G*Power 3.1, "ANOVA: repeated measures, within factors", f = 0.25, alpha = 0.05, power 0.95, one
    group, 3 measurements, rho = 0.5, epsilon = 1: total sample size 43, lambda 16.125, F crit 3.1052."""
    table = pw.gpower_table(3, 0.25, 0.5, 1.0, 0.05, n_values=(), targets=(0.95,))
    row = table.iloc[0]
    assert row["n"] == 43 and row["lambda"] == pytest.approx(16.125) and row["F_crit"] == pytest.approx(3.1052, abs=1e-4)
    assert pd.isna(pw.gpower_table(3, 0.0, targets=(0.8,))["n"].iloc[0])


REFUSED = [
    (pw.rm_anova_power, (11, 3), dict(f=0.25, rho=-0.6), "rho"),          # below -1/(m-1) = -0.5
    (pw.rm_anova_power, (11, 5), dict(f=0.25, rho=-0.3), "-1/(m-1)"),     # below -0.25
    (pw.rm_anova_power, (11, 3), dict(f=0.25, rho=1.0), "rho"),
    (pw.rm_anova_power, (11, 3), dict(f=0.25, rho=np.nan), "rho"),
    (pw.rm_anova_power, (11, 3), dict(f=1e300, rho=0.5), "f must be at most"),
    (pw.rm_anova_power, (11, 3), dict(f=1e150, rho=1 - 1e-12), "beyond the range of doubles"),
    (pw.rm_anova_power, (11, 3), dict(f=0.25, rho=0.5, alpha=1.5), "alpha"),
    (pw.rm_anova_power, (11, 3), dict(f=0.25, rho=0.5, alpha=-0.1), "alpha"),
    (pw.rm_anova_power, (11, 3), dict(f=0.25, rho=0.5, alpha=np.nan), "alpha"),
    (pw.rm_anova_power, (11, 3), dict(f="0.25", rho=0.5), "f must be a number"),
    (pw.rm_anova_sample_size, (1.2, 3), dict(f=0.25, rho=0.5), "power"),
    (pw.noncentrality_interval, (3.0, 2, 20), dict(confidence=1.5), "confidence"),
    (pw.noncentrality_interval, (np.nan, 2, 20), {}, "F must be"),
    (pw.effect_size_from_f, (np.inf, 2, 20), {}, "F must be"),
    (pw.replication_plan, (1e300, 2, 20), {}, "rounds to 1"),
    (pw.wilson_interval, (np.nan, 10), {}, "finite"),
    (pw.wilson_interval, (3, np.inf), {}, "finite"),
    (pw.recommended_n, ([4, 6], [0.5, np.nan], 0.8), {}, "probabilities"),
    (pw.recommended_n, ([4, 6], [0.5, 1.5], 0.8), {}, "probabilities"),
    (pw.noncentral_f_sf, (3.0, 2, 20, -1.0), {}, "nc >= 0"),
    (pw.noncentral_f_sf, (np.nan, 2, 20, 1.0), {}, "a number x"),
]


@pytest.mark.parametrize("fn, args, kwargs, phrase", REFUSED,
                         ids=[f"{c[0].__name__}-{i}" for i, c in enumerate(REFUSED)])
def test_impossible_parameters_are_refused(fn, args, kwargs, phrase):
    with pytest.raises(ValueError, match=phrase.replace("(", r"\(").replace(")", r"\)")):
        fn(*args, **kwargs)


def test_rho_at_the_bound_is_allowed():
    assert 0 < pw.rm_anova_power(11, 3, f=0.25, rho=-0.5) < 1


@pytest.mark.parametrize("f, rho, n", [(0.3, 0.5, 12), (0.25, 0.7, 10), (0.4, 0.2, 8)])
def test_analytic_power_agrees_with_gaussian_simulation(f, rho, n):
    """Compound symmetry (sphericity): G*Power's F power and the exact Tukey and paired-t powers."""
    means, cov = rb.means_with_effect(f, 3), rb.compound_symmetry(3, rho)
    reps = 6000
    sim = rb.gaussian_rm_power(means, cov, n, reps=reps, seed=7)
    se = lambda p: 4 * np.sqrt(p * (1 - p) / reps)  # noqa: E731
    analytic = pw.rm_anova_power(n, 3, f=f, rho=rho)
    assert abs(sim["anova"] / reps - analytic) < se(analytic)
    for k, (i, j) in enumerate(sim["pairs"]):
        dz = (means[i] - means[j]) / np.sqrt(2 * (1 - rho))
        tukey, paired = pw.tukey_rm_power(dz, n, 3), pw.paired_t_power(dz, n)
        assert abs(sim["tukey"][k] / reps - tukey) < se(tukey)
        assert abs(sim["paired"][k] / reps - paired) < se(paired)
        # Holm rejects at least what Bonferroni does and at most what the uncorrected test does
        bonferroni = pw.paired_t_power(dz, n, comparisons=3)
        assert bonferroni - se(bonferroni) < sim["holm"][k] / reps < paired + se(paired)


GOOD = dict(f=0.3, rho=0.5)


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
]


@pytest.mark.parametrize("fn, args, kwargs, phrase", CASES,
                         ids=[f"{getattr(c[0], '__name__', 'call')}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, phrase):
    with pytest.raises(ValueError) as err:
        fn(*args, **kwargs)
    assert phrase in str(err.value), f"{err.value!s} does not say {phrase!r}"
