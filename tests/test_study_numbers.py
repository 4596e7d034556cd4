"""Numbers that stay numbers (issue 22, section 2) in the study statistics and the power analysis: power
at zero effect is alpha, the noncentral F is guarded where scipy fails, impossible parameters are refused,
and the repeated-measures ANOVA gives the same answer whatever the data's units (1e-170 or 1e170)."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from mutual.study import paired_t_holm, rm_anova, tukey_rm
from mutual.study import power as pw

# ---- zero effect and the noncentral F ---------------------------------------------------------------


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


# ---- impossible parameters are refused -------------------------------------------------------------

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


# ---- the RM-ANOVA in any units ---------------------------------------------------------------------

def _long(y, scale):
    return pd.DataFrame([{"s": f"s{i}", "l": f"L{j}", "v": y[i, j] * scale}
                         for i in range(y.shape[0]) for j in range(y.shape[1])])


@pytest.fixture(scope="module")
def cells():
    return np.random.default_rng(22).normal(size=(7, 3)) + [0.0, 0.2, 0.5]


@pytest.mark.parametrize("scale", [1e-170, 1e-300, 1e-200, 2.0 ** -1000, 1e100, 1e170, 1e300, 3.7e-20])
def test_the_anova_does_not_depend_on_the_units(cells, scale):
    base = rm_anova(_long(cells, 1.0), "v", "l", "s")
    res = rm_anova(_long(cells, scale), "v", "l", "s")
    for key in ("F", "p", "eps", "p_gg", "eta2p", "eta2g"):
        assert getattr(res, key) == pytest.approx(getattr(base, key), rel=1e-12), key
    assert res.root_mse == pytest.approx(base.root_mse * scale, rel=1e-12)
    assert tukey_rm(res)["p"].to_numpy() == pytest.approx(tukey_rm(base)["p"].to_numpy(), rel=1e-10)
    assert paired_t_holm(res)["t"].to_numpy() == pytest.approx(paired_t_holm(base)["t"].to_numpy(), rel=1e-10)
    assert list(res.standard_errors().values()) == pytest.approx(
        [v * scale for v in base.standard_errors().values()], rel=1e-12)


def test_constant_data_at_any_scale_still_does_not_vary(cells):
    from mutual.study import DegenerateDataError
    for scale in (1e-300, 1.0, 1e300):
        with pytest.raises(DegenerateDataError, match="does not vary"):
            rm_anova(_long(np.ones((4, 3)), scale), "v", "l", "s")


def test_the_sums_of_squares_are_pingouins_decomposition(cells):
    res = rm_anova(_long(cells, 1.0), "v", "l", "s")
    y = cells
    total = ((y - y.mean()) ** 2).sum()
    assert res.ss_effect + res.ss_error + res.ss_subjects == pytest.approx(total, rel=1e-12)
    assert res.eta2g == pytest.approx(res.ss_effect / total, rel=1e-12)
    assert res.eta2p == pytest.approx(res.ss_effect / (res.ss_effect + res.ss_error), rel=1e-12)
    assert res.ms_effect == pytest.approx(res.ss_effect / res.df1) and res.ms_error == res.mse
