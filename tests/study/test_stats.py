"""Repeated-measures statistics against independent reference numbers: pingouin's on its shipped dataset
``pairwise_tests`` (11 subjects x 3 drugs, the thesis's shape; copied from pingouin's
``src/pingouin/datasets/pairwise_tests.csv``), statsmodels' AnovaRM and scipy on random balanced designs
(hypothesis), and the definitions (Holm, the eigenvalue form of the Greenhouse-Geisser epsilon); the same
answer whatever the data's units; degenerate data refused, never NaN; bad inputs (a table)."""

import json

import numpy as np
import pandas as pd
import pytest
from hypothesis import assume, given, settings, strategies as hst
from scipy import stats
from statsmodels.stats.anova import AnovaRM

from mutual.study.stats import (DegenerateDataError, RMAnova, cell_table, greenhouse_geisser_epsilon,
                                likert_vs_neutral, paired_t_holm, rm_anova, significance_stars, tukey_from_summary,
                                tukey_rm)

from helpers.study import case_id, resolve


def test_rm_anova_matches_pingouin(pairwise):
    res = rm_anova(pairwise, "Scores", "Drug", "Subject")
    assert (res.df_num, res.df_den, res.n_subjects) == (2, 20, 11)
    assert res.F == pytest.approx(1.450292398, rel=1e-8)
    assert res.p == pytest.approx(0.2581274727, rel=1e-8)
    assert res.mse == pytest.approx(2.590909091, rel=1e-8)
    assert res.epsilon_gg == pytest.approx(0.8574339089, rel=1e-8)
    # GG-corrected p: the F distribution with epsilon-scaled degrees of freedom
    assert res.p_gg == pytest.approx(stats.f.sf(res.F, 2 * res.epsilon_gg, 20 * res.epsilon_gg))
    assert res.p_gg > res.p


def test_tukey_rm_matches_pingouin(pairwise):
    tk = tukey_rm(rm_anova(pairwise, "Scores", "Drug", "Subject")).set_index(["A", "B"])["p"]
    assert tk[("A", "B")] == pytest.approx(0.273106, abs=2e-6)
    assert tk[("A", "C")] == pytest.approx(0.398489, abs=2e-6)
    assert tk[("B", "C")] == pytest.approx(0.962127, abs=2e-6)


def test_paired_t_holm_matches_pingouin_and_holm_by_hand(pairwise):
    res = paired_t_holm(rm_anova(pairwise, "Scores", "Drug", "Subject").cells).set_index(["A", "B"])
    assert res.loc[("A", "B"), "t"] == pytest.approx(-1.4201432, rel=1e-7)
    assert res.loc[("A", "B"), "p"] == pytest.approx(0.18598346, rel=1e-7)
    p = res["p"].to_numpy()
    order = np.argsort(p)
    holm = np.maximum.accumulate(np.minimum(1, p[order] * (len(p) - np.arange(len(p)))))
    assert np.allclose(res["p_holm"].to_numpy()[order], holm)


def test_mse_and_f_from_sums_of_squares(pairwise):
    y = pairwise.pivot(index="Subject", columns="Drug", values="Scores").to_numpy(float)
    n, k = y.shape
    ss_a = n * ((y.mean(0) - y.mean()) ** 2).sum()
    ss_s = k * ((y.mean(1) - y.mean()) ** 2).sum()
    ss_e = ((y - y.mean()) ** 2).sum() - ss_a - ss_s
    res = rm_anova(pairwise, "Scores", "Drug", "Subject")
    assert res.F == pytest.approx(ss_a / (k - 1) / (ss_e / ((k - 1) * (n - 1))))


def test_tukey_two_levels_equals_paired_t():
    # with k = 2, q = sqrt(2) |t| and the studentized range test equals the paired t-test
    rng = np.random.default_rng(1)
    y = rng.normal(size=(9, 2)) + [0, 0.8]
    df = pd.DataFrame({"s": np.repeat(np.arange(9), 2), "c": np.tile(["a", "b"], 9), "v": y.ravel()})
    res = rm_anova(df, "v", "c", "s")
    assert tukey_rm(res)["p"].iloc[0] == pytest.approx(stats.ttest_rel(y[:, 0], y[:, 1]).pvalue, rel=1e-6)
    assert res.epsilon_gg == pytest.approx(1.0)


def test_bad_input_raises(pairwise):
    with pytest.raises(ValueError, match="NaN"):
        rm_anova(pairwise.assign(Scores=pairwise["Scores"].where(pairwise.index != 3)), "Scores", "Drug", "Subject")
    with pytest.raises(ValueError, match="unbalanced"):
        rm_anova(pairwise.drop(index=5), "Scores", "Drug", "Subject")
    with pytest.raises(ValueError, match="several rows"):
        rm_anova(pd.concat([pairwise, pairwise.iloc[[0]]]), "Scores", "Drug", "Subject")
    with pytest.raises(ValueError, match="missing columns"):
        cell_table(pairwise, "Score", "Drug", "Subject")
    with pytest.raises(ValueError, match="1..7"):
        likert_vs_neutral([4, 5, 8])
    with pytest.raises(ValueError, match="mse"):
        tukey_from_summary({"a": 1, "b": 2}, -1.0, 5)


def test_likert_vs_neutral_matches_scipy():
    answers = [4, 5, 3, 4, 6, 2, 4, 5, 4, 3, 5]
    res = likert_vs_neutral(answers)
    ref = stats.ttest_1samp(answers, 4)
    assert res["t"] == pytest.approx(ref.statistic) and res["p"] == pytest.approx(ref.pvalue)


def test_missing_cell_in_study_data_raises(questionnaire):
    trust = questionnaire[questionnaire["measure"] == "trust"]
    gone = trust[~((trust["participant"] == "P02") & (trust["treatment"] == "Learned"))]
    with pytest.raises(ValueError, match="unbalanced"):
        rm_anova(gone, "value", "treatment", "participant", aggregate="mean")


@hst.composite
def balanced_designs(draw, max_subjects=8, max_levels=5):
    """A random balanced subject x level table of values with two decimals (ties and counts included)."""
    n = draw(hst.integers(2, max_subjects))
    k = draw(hst.integers(2, max_levels))
    scale = draw(hst.sampled_from([1, 100]))
    cells = draw(hst.lists(hst.integers(-20 * scale, 20 * scale), min_size=n * k, max_size=n * k))
    return np.array(cells, dtype=float).reshape(n, k) / scale


def _long(y, names=None):
    n, k = y.shape
    names = names or [f"level {j}" for j in range(k)]
    return pd.DataFrame({"who": np.repeat([f"s{i}" for i in range(n)], k), "cond": np.tile(names, n), "y": y.ravel()})


def _sums_of_squares(y):
    n, k = y.shape
    grand = y.mean()
    ss_a = n * ((y.mean(0) - grand) ** 2).sum()
    ss_e = ((y - y.mean(1, keepdims=True) - y.mean(0, keepdims=True) + grand) ** 2).sum()
    return ss_a, ss_e


@settings(max_examples=60, deadline=None, derandomize=True)
@given(balanced_designs())
def test_rm_anova_agrees_with_statsmodels_anovarm(y):
    data = _long(y)
    ss_a, ss_e = _sums_of_squares(y)
    scale = np.abs(y).max()
    if ss_e <= 1e-9 * max(scale, 1) ** 2:            # zero residual variance: F is 0/0 or infinite
        with pytest.raises(DegenerateDataError):
            rm_anova(data, "y", "cond", "who")
        return
    res = rm_anova(data, "y", "cond", "who")
    ref = AnovaRM(data, "y", "who", within=["cond"]).fit().anova_table.iloc[0]
    assert (res.df1, res.df2) == (int(ref["Num DF"]), int(ref["Den DF"]))
    assert res.F == pytest.approx(float(ref["F Value"]), rel=1e-7, abs=1e-9)
    assert res.p == pytest.approx(float(ref["Pr > F"]), rel=1e-6, abs=1e-12)
    assert res.F >= 0 and np.isfinite([res.F, res.p, res.eps, res.p_gg, res.mse]).all()
    assert res.mse == pytest.approx(ss_e / res.df2)


def _gg_epsilon_by_contrasts(y):
    """Box's epsilon from the covariance of orthonormal contrasts (eigenvalue form), a second derivation."""
    k = y.shape[1]
    helmert = np.array([[1.0] * j + [-j] + [0.0] * (k - j - 1) for j in range(1, k)]).T   # k x (k-1), columns sum to 0
    m, _ = np.linalg.qr(helmert)
    lam = np.linalg.eigvalsh(m.T @ np.cov(y, rowvar=False) @ m)
    return lam.sum() ** 2 / ((k - 1) * (lam ** 2).sum())


@settings(max_examples=60, deadline=None, derandomize=True)
@given(balanced_designs(max_subjects=10))
def test_greenhouse_geisser_epsilon_agrees_with_the_eigenvalue_form(y):
    assume(np.cov(y, rowvar=False).trace() > 1e-6)
    k = y.shape[1]
    eps = greenhouse_geisser_epsilon(y)
    assert 1 / (k - 1) - 1e-12 <= eps <= 1 + 1e-12
    assert eps == pytest.approx(_gg_epsilon_by_contrasts(y), rel=1e-7)


def test_gg_epsilon_is_one_for_two_levels_and_for_sphericity():
    rng = np.random.default_rng(0)
    assert greenhouse_geisser_epsilon(rng.normal(size=(7, 2))) == pytest.approx(1.0)
    # compound symmetry (equal variances and covariances) is spherical: eps = 1 in expectation; exactly 1 here
    base = rng.normal(size=(500, 1))
    y = base + rng.normal(size=(500, 4))
    assert greenhouse_geisser_epsilon(y) > 0.98


@settings(max_examples=40, deadline=None, derandomize=True)
@given(balanced_designs(max_levels=4))
def test_paired_t_holm_agrees_with_scipy(y):
    wide = pd.DataFrame(y, columns=[f"c{j}" for j in range(y.shape[1])])
    diffs = [y[:, i] - y[:, j] for i in range(y.shape[1]) for j in range(i + 1, y.shape[1])]
    if any(np.ptp(d) <= 1e-9 for d in diffs):
        with pytest.raises(DegenerateDataError):
            paired_t_holm(wide)
        return
    res = paired_t_holm(wide)
    ref = [stats.ttest_rel(y[:, i], y[:, j]).pvalue for i in range(y.shape[1]) for j in range(i + 1, y.shape[1])]
    assert np.allclose(res["p"], ref, rtol=1e-9)
    assert np.isfinite(res[["t", "p", "p_holm"]].to_numpy()).all()


@pytest.mark.parametrize("names", [["low", "high"], ["A-1", "B 2", "c"], ["ø", "ß", "日本", "x"], ["1", "2", "3", "4", "5"]])
def test_any_treatment_names_and_levels(names):
    rng = np.random.default_rng(len(names))
    y = rng.normal(size=(6, len(names))) + np.arange(len(names))
    data = _long(y, names)
    res = rm_anova(data, dv="y", within="cond", subject="who")
    assert res.levels == tuple(sorted(names)) and res.df1 == len(names) - 1
    d = res.to_dict()
    assert {"F", "df1", "df2", "p", "eps", "p_gg"} <= set(d) and d["levels"] == sorted(names)
    json.dumps(d)                                           # plain values only
    pairs = tukey_rm(res)
    assert len(pairs) == len(names) * (len(names) - 1) // 2
    assert len(paired_t_holm(data, dv="y", within="cond", subject="who")) == len(pairs)
    assert tukey_rm(data, "y", "cond", "who")["p"].tolist() == pytest.approx(pairs["p"].tolist())


def test_results_print_short_summaries(pairwise):
    res = rm_anova(pairwise, "Scores", "Drug", "Subject")
    text = repr(res)
    assert len(text) < 300 and "F(2, 20) = 1.45" in text and "Scores ~ Drug | Subject" in text
    assert isinstance(res, RMAnova) and (res.df_num, res.df_den, res.epsilon_gg) == (res.df1, res.df2, res.eps)


def test_dv_may_name_a_measure_of_a_tidy_table(questionnaire):
    by_measure = rm_anova(questionnaire, "trust", "treatment", "participant", aggregate="mean")
    trust = questionnaire[questionnaire["measure"] == "trust"]
    by_column = rm_anova(trust, "value", "treatment", "participant", aggregate="mean")
    assert by_measure.F == pytest.approx(by_column.F) and by_measure.dv == "trust"


def test_degenerate_data_is_refused_not_nan(pairwise):
    zeros = pairwise.assign(Scores=0)
    with pytest.raises(DegenerateDataError, match="'Scores' does not vary within subjects"):
        rm_anova(zeros, "Scores", "Drug", "Subject")
    additive = pairwise.assign(Scores=pairwise["Subject"] + pairwise["Drug"].map({"A": 0, "B": 1, "C": 3}))
    with pytest.raises(DegenerateDataError, match="zero residual variance"):
        rm_anova(additive, "Scores", "Drug", "Subject")
    with pytest.raises(DegenerateDataError, match="all 4 answers are 5"):
        likert_vs_neutral([5, 5, 5, 5])
    wide = pairwise.pivot(index="Subject", columns="Drug", values="Scores").assign(D=lambda t: t["A"])
    with pytest.raises(DegenerateDataError, match="'A' and 'D'.*identical"):
        paired_t_holm(wide)
    # no treatment effect at all, but residual variance: F = 0 and p = 1, not NaN
    y = np.array([[1.0, 2.0], [2.0, 1.0], [3.0, 3.5], [4.0, 3.5]])
    res = rm_anova(_long(y), "y", "cond", "who")
    assert res.F == 0.0 and res.p == pytest.approx(1.0)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(hst.lists(hst.floats(0, 1), min_size=1, max_size=12))
def test_holm_matches_its_definition(p):
    """Holm by brute force: reject H_(i) at level a iff p_(j) <= a / (m - j + 1) for every j <= i, so the adjusted
    p of H_(i) is the smallest a that does so, max_{j <= i} (m - j + 1) p_(j), capped at 1."""
    from mutual.study.stats import holm
    m = len(p)
    ranked = sorted(range(m), key=lambda i: (p[i], i))
    brute = [0.0] * m
    for r, i in enumerate(ranked):
        brute[i] = min(1.0, max((m - j) * p[ranked[j]] for j in range(r + 1)))
    assert np.allclose(holm(p), brute)


def test_holm_matches_statsmodels():
    from statsmodels.stats.multitest import multipletests
    from mutual.study.stats import holm
    p = [0.01, 0.04, 0.03, 0.005, 0.2, 0.04]
    assert np.allclose(holm(p), multipletests(p, method="holm")[1])


def test_pairwise_comparisons_are_json_ready(pairwise):
    from mutual.study.stats import pairwise_comparisons
    res = rm_anova(pairwise, "Scores", "Drug", "Subject")
    rows = pairwise_comparisons(res, as_records=True)
    assert json.loads(json.dumps(rows)) == rows and len(rows) == 3
    ab = next(r for r in rows if (r["A"], r["B"]) == ("A", "B"))
    assert ab["p_tukey"] == pytest.approx(0.273106, abs=2e-6) and ab["p_t"] == pytest.approx(0.18598346, rel=1e-7)
    assert ab["df"] == 10 and ab["diff"] == pytest.approx(res.means["A"] - res.means["B"])


def _scaled_long(y, scale):
    return pd.DataFrame([{"s": f"s{i}", "l": f"L{j}", "v": y[i, j] * scale}
                         for i in range(y.shape[0]) for j in range(y.shape[1])])


@pytest.fixture(scope="module")
def cells():
    return np.random.default_rng(22).normal(size=(7, 3)) + [0.0, 0.2, 0.5]


@pytest.mark.parametrize("scale", [1e-170, 1e-300, 1e-200, 2.0 ** -1000, 1e100, 1e170, 1e300, 3.7e-20])
def test_the_anova_does_not_depend_on_the_units(cells, scale):
    base = rm_anova(_scaled_long(cells, 1.0), "v", "l", "s")
    res = rm_anova(_scaled_long(cells, scale), "v", "l", "s")
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
            rm_anova(_scaled_long(np.ones((4, 3)), scale), "v", "l", "s")


def test_the_sums_of_squares_are_pingouins_decomposition(cells):
    res = rm_anova(_scaled_long(cells, 1.0), "v", "l", "s")
    y = cells
    total = ((y - y.mean()) ** 2).sum()
    assert res.ss_effect + res.ss_error + res.ss_subjects == pytest.approx(total, rel=1e-12)
    assert res.eta2g == pytest.approx(res.ss_effect / total, rel=1e-12)
    assert res.eta2p == pytest.approx(res.ss_effect / (res.ss_effect + res.ss_error), rel=1e-12)
    assert res.ms_effect == pytest.approx(res.ss_effect / res.df1) and res.ms_error == res.mse


@pytest.mark.parametrize("columns", [["A", "B", "A"], ["A", "B", "A "], ["x", "x"]])
def test_wide_tables_with_a_repeated_level_are_refused(columns):
    wide = pd.DataFrame(np.random.default_rng(0).normal(size=(6, len(columns))), columns=columns)
    with pytest.raises(ValueError, match="'A'|'x'"):
        paired_t_holm(wide)
    with pytest.raises(ValueError, match="'A'|'x'"):
        greenhouse_geisser_epsilon(wide)


def test_rm_anova_keeps_text_levels_in_memory():
    data = pd.DataFrame({"s": ["01", "01", "1", "1", "2", "2"], "l": ["NA", "None"] * 3, "y": [1.0, 3, 2, 5, 4, 5]})
    res = rm_anova(data, "y", "l", "s")
    assert res.n_subjects == 3 and res.levels == ("NA", "None")


def _long_table(values, levels=("a", "b", "c"), n=4):
    y = np.asarray(values, dtype=float).reshape(n, len(levels))
    return pd.DataFrame({"who": np.repeat([f"s{i}" for i in range(n)], len(levels)),
                         "cond": np.tile(levels, n), "y": y.ravel()})


GOOD = _long_table(np.arange(12) % 5 + np.repeat([0, 2, 1, 3], 3))
WIDE = pd.DataFrame({"a": [1.0, 2.0, 3.0, 5.0], "b": [2.0, 2.5, 4.5, 6.0], "c": [0.0, 1.0, 3.0, 2.0]})


CASES = [
    # --- rm_anova / cell_table: arguments and data
    (rm_anova, ([1, 2, 3], "y", "cond", "who"), {}, ValueError, "data must be a pandas DataFrame"),
    (rm_anova, (GOOD, "nope", "cond", "who"), {}, ValueError, "missing columns ['nope']"),
    (rm_anova, (GOOD, "y", "cond", "cond"), {}, ValueError, "three different columns"),
    (rm_anova, (GOOD, 5, "cond", "who"), {}, ValueError, "dv must name a column"),
    (rm_anova, (GOOD.iloc[:0], "y", "cond", "who"), {}, ValueError, "data has no rows"),
    (rm_anova, (GOOD.assign(y=GOOD["y"].where(GOOD.index != 4)), "y", "cond", "who"), {}, ValueError,
     "column 'y' has a missing value (NaN) in row 4"),
    (rm_anova, (GOOD.assign(y=GOOD["y"].astype(object).where(GOOD.index != 2, "many")), "y", "cond", "who"), {},
     ValueError, "column 'y' must be numeric: row 2 holds 'many'"),
    (rm_anova, (GOOD.assign(y=GOOD["y"].where(GOOD.index != 1, np.inf)), "y", "cond", "who"), {}, ValueError,
     "must hold finite numbers: row 1"),
    (rm_anova, (pd.concat([GOOD, GOOD.iloc[[0]]]), "y", "cond", "who"), {}, ValueError, "aggregate='mean'"),
    (rm_anova, (GOOD, "y", "cond", "who"), {"aggregate": "median"}, ValueError, "aggregate must be None or 'mean'"),
    (rm_anova, (GOOD.drop(index=5), "y", "cond", "who"), {}, ValueError, "unbalanced design: subject(s) ['s1']"),
    (rm_anova, (GOOD[GOOD.cond == "a"], "y", "cond", "who"), {}, ValueError, "need at least 2 subjects and 2 levels"),
    (rm_anova, (GOOD[GOOD.who == "s0"], "y", "cond", "who"), {}, ValueError, "got 1 subject(s)"),
    (rm_anova, (GOOD, "y", "cond", "who"), {"levels": ("a", "b")}, ValueError, "level(s) ['c'] not among levels"),
    (rm_anova, (GOOD, "y", "cond", "who"), {"levels": ("a", "b", "c", "d")}, ValueError, "level(s) ['d'] of levels have no rows"),
    (rm_anova, (GOOD, "y", "cond", "who"), {"levels": ("a", "a", "b", "c")}, ValueError, "must not repeat"),
    (rm_anova, (GOOD, "y", "cond", "who"), {"levels": "abc"}, ValueError, "levels must be a list of the levels of 'cond'"),
    # --- degenerate data: an error naming the measure and the reason, never NaN or a negative F
    (rm_anova, (GOOD.assign(y=0.0), "y", "cond", "who"), {}, DegenerateDataError,
     "'y' does not vary within subjects (every value is 0)"),
    (rm_anova, (GOOD.assign(y=7.5), "y", "cond", "who"), {}, DegenerateDataError, "every value is 7.5"),
    (rm_anova, (GOOD.assign(y=GOOD["who"].str[1].astype(float)), "y", "cond", "who"), {}, DegenerateDataError,
     "every subject has one value at every level"),
    (rm_anova, (GOOD.assign(y=GOOD["who"].str[1].astype(float) + GOOD["cond"].map({"a": 0, "b": 1, "c": 5})),
                "y", "cond", "who"), {}, DegenerateDataError, "zero residual variance"),
    (rm_anova, (pd.DataFrame({"participant": ["P1", "P1", "P2", "P2"], "treatment": ["A", "B"] * 2,
                              "measure": "collisions", "value": 0}), "collisions", "treatment", "participant"), {},
     DegenerateDataError, "'collisions' does not vary within subjects"),
    (likert_vs_neutral, ([5, 5, 5, 5],), {}, DegenerateDataError, "all 4 answers are 5"),
    (paired_t_holm, (WIDE.assign(d=WIDE["a"]),), {}, DegenerateDataError, "levels 'a' and 'd': the paired differences are identical"),
    (paired_t_holm, (WIDE.assign(d=WIDE["a"] + 2),), {}, DegenerateDataError, "the same for every subject (-2)"),
    # --- the other statistics
    (likert_vs_neutral, ([4],), {}, ValueError, "at least 2 answers"),
    (likert_vs_neutral, ([4, 9, 3],), {}, ValueError, "whole numbers in 1..7"),
    (likert_vs_neutral, ([4, 5.5],), {}, ValueError, "whole numbers in 1..7"),
    (likert_vs_neutral, (["agree", "neutral"],), {}, ValueError, "answers must be numbers"),
    (likert_vs_neutral, ([4, 5, 3],), {"neutral": 9}, ValueError, "neutral must be a number in 1..7"),
    (paired_t_holm, (WIDE.assign(c=[1.0, np.nan, 2.0, 3.0]),), {}, ValueError, "complete table of finite numbers"),
    (paired_t_holm, ([1, 2, 3],), {}, ValueError, "cells must be a subject x level DataFrame"),
    (paired_t_holm, (WIDE[["a"]],), {}, ValueError, ">= 2 levels"),
    (paired_t_holm, (WIDE.assign(c=["x", "y", "z", "w"]),), {}, ValueError, "cells must hold numbers only"),
    (tukey_rm, (GOOD,), {}, ValueError, "pass an RMAnova, or long data with dv, within and subject"),
    (tukey_from_summary, ({"a": 1.0}, 1.0, 5), {}, ValueError, "at least 2 levels"),
    (tukey_from_summary, ({"a": 1.0, "b": float("nan")}, 1.0, 5), {}, ValueError, "level(s) ['b'] are not"),
    (tukey_from_summary, ({"a": 1.0, "b": 2.0}, 0.0, 5), {}, ValueError, "mse must be a positive finite number"),
    (tukey_from_summary, ({"a": 1.0, "b": 2.0}, 1.0, 1.5), {}, ValueError, "n must be an integer >= 2"),
    (greenhouse_geisser_epsilon, ([[1.0, 2.0]],), {}, ValueError, ">= 2 rows and columns"),
    (significance_stars, (float("nan"),), {}, ValueError, "p must be a probability in [0, 1]"),
]


@pytest.mark.parametrize("function, args, kwargs, exception, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_is_named(function, args, kwargs, exception, phrase, tmp_path, functions):
    args = [resolve(a, tmp_path, functions) for a in args]
    with pytest.raises(exception) as info:
        function(*args, **kwargs)
    assert phrase in str(info.value)


def test_degenerate_errors_are_value_errors():
    """One ``except ValueError`` catches every refusal of the study's statistics."""
    assert issubclass(DegenerateDataError, ValueError)


def test_suite_size():
    assert len(CASES) >= 35
