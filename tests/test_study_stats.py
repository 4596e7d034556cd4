"""Study statistics against independent reference numbers.

The fixture is pingouin's shipped dataset ``pairwise_tests`` (11 subjects x 3
drugs, the thesis's shape), copied from pingouin's
``src/pingouin/datasets/pairwise_tests.csv``; the reference numbers are those
pingouin (``rm_anova``, repeated-measures Tukey, ``pairwise_tests``) and
statsmodels give on it.
"""

import io

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from mutual.study.data import illustrative_questionnaire, read_table, validate_trials, write_table
from mutual.study.design import study_design
from mutual.study.published import design_from_f_dofs, f_p_value, recover_from_summary, rounding_range, table_5_1_ratios
from mutual.study.stats import (DegenerateDataError, RMAnova, cell_table, greenhouse_geisser_epsilon, likert_vs_neutral,
                                paired_t_holm, rm_anova, tukey_from_summary, tukey_rm)

PAIRWISE_TESTS = """Subject,Gender,Drug,Scores
1,M,A,4
2,M,A,5
3,M,A,3
4,M,A,4
5,M,A,2
6,M,A,7
7,F,A,5
8,F,A,4
9,F,A,2
10,F,A,3
11,F,A,5
1,M,B,6
2,M,B,4
3,M,B,8
4,M,B,9
5,M,B,4
6,M,B,5
7,F,B,6
8,F,B,4
9,F,B,5
10,F,B,1
11,F,B,4
1,M,C,5
2,M,C,6
3,M,C,6
4,M,C,4
5,M,C,5
6,M,C,4
7,F,C,4
8,F,C,5
9,F,C,4
10,F,C,4
11,F,C,7
"""


@pytest.fixture
def pairwise():
    return pd.read_csv(io.StringIO(PAIRWISE_TESTS))


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


def test_recover_from_summary_round_trip(pairwise):
    res = rm_anova(pairwise, "Scores", "Drug", "Subject")
    rec = recover_from_summary(res.means, res.F, 2, 20)
    assert rec["n"] == 11
    assert rec["mse"] == pytest.approx(res.mse)
    assert np.allclose(rec["tukey"]["p"], tukey_rm(res)["p"])


def test_thesis_summary_numbers():
    rec = recover_from_summary({"Standard": 12.54, "Learned": 7.31, "Conservative": 4.68}, 8.72, 2, 20)
    tk = rec["tukey"].set_index(["A", "B"])["p"]
    assert tk[("Standard", "Learned")] == pytest.approx(0.0328, abs=0.001)
    assert tk[("Standard", "Conservative")] < 0.01
    assert tk[("Learned", "Conservative")] > 0.05
    assert rec["p"] < 0.01
    assert f_p_value(1.86, 1, 9) == pytest.approx(0.21, abs=0.005)
    assert design_from_f_dofs(1, 9) == {"levels": 2, "subjects": 10}


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


@pytest.fixture
def questionnaire():
    return illustrative_questionnaire(study_design(12), seed=3)


def test_study_table_round_trip(tmp_path, questionnaire):
    path = write_table(questionnaire, tmp_path / "q.csv", "trials")
    back = read_table(path, "trials")
    pd.testing.assert_frame_equal(back, questionnaire.reset_index(drop=True), check_dtype=False)


@pytest.mark.parametrize("corrupt, message", [
    (lambda d: d.drop(columns="trial"), "missing column 'trial'"),
    (lambda d: d.assign(value=d["value"].where(d.index != 7)), "row 7, column 'value': empty"),
    (lambda d: pd.concat([d, d.iloc[[4]]]), "duplicate"),
    (lambda d: d.assign(value=d["value"].where(d.index != 2, 9)), "Likert"),
    (lambda d: d.assign(treatment=d["treatment"].where(d.index != 0, "Reckless")), "does not name this row's treatment"),
])
def test_bad_study_data_raises(questionnaire, corrupt, message):
    with pytest.raises(ValueError, match=message):
        validate_trials(corrupt(questionnaire))


def test_missing_cell_in_study_data_raises(questionnaire):
    trust = questionnaire[questionnaire["measure"] == "trust"]
    gone = trust[~((trust["participant"] == "P02") & (trust["treatment"] == "Learned"))]
    with pytest.raises(ValueError, match="unbalanced"):
        rm_anova(gone, "value", "treatment", "participant", aggregate="mean")


# --------------------------------------------------------------------------- second implementations (hypothesis)

from hypothesis import assume, given, settings, strategies as hst
from statsmodels.stats.anova import AnovaRM


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


# --------------------------------------------------------------------------- any treatment names, users' words

@pytest.mark.parametrize("names", [["low", "high"], ["A-1", "B 2", "c"], ["ø", "ß", "日本", "x"], ["1", "2", "3", "4", "5"]])
def test_any_treatment_names_and_levels(names):
    rng = np.random.default_rng(len(names))
    y = rng.normal(size=(6, len(names))) + np.arange(len(names))
    data = _long(y, names)
    res = rm_anova(data, dv="y", within="cond", subject="who")
    assert res.levels == tuple(sorted(names)) and res.df1 == len(names) - 1
    d = res.to_dict()
    assert {"F", "df1", "df2", "p", "eps", "p_gg"} <= set(d) and d["levels"] == sorted(names)
    import json
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


def test_rounding_range_and_table_ratios():
    means = {"Standard": 12.54, "Learned": 7.31, "Conservative": 4.68}
    rr = rounding_range(means, 8.72, 2, 20).set_index(["A", "B"])
    row = rr.loc[("Standard", "Learned")]
    assert row["p_low"] < row["p"] < row["p_high"] and row["p_high"] - row["p_low"] < 0.001
    assert row["p_low"] <= 0.0328 <= row["p_high"]          # the thesis's reported value is within rounding
    table = pd.DataFrame({"safe_set": ["Standard", "Learned", "Conservative"], "interventions_in_safe_set": [397, 220, 115],
                          "interventions": [440] * 3, "predicted_fp_vs_standard": [1, 0.554, 0.29],
                          "average_fp": [12.54, 7.31, 4.68], "observed_fp_vs_standard": [1, 0.583, 0.373]})
    r = table_5_1_ratios(table)
    assert r["predicted"]["Learned"] == pytest.approx(220 / 397) and r["learned_half"] == 0.5
    assert r["observed"]["Conservative"] == pytest.approx(4.68 / 12.54)


def test_read_table_accepts_any_treatment_names(tmp_path, questionnaire):
    renamed = questionnaire.replace({"Standard": "baseline", "Learned": "our-method", "Conservative": "cautious"})
    renamed["comparison"] = renamed["comparison"].str.replace("Standard", "baseline").str.replace(
        "Learned", "our-method").str.replace("Conservative", "cautious")
    path = write_table(renamed, tmp_path / "t.csv", "trials")
    back = read_table(path, "trials")
    assert set(back["treatment"]) == {"baseline", "our-method", "cautious"}
    res = rm_anova(back, "trust", "treatment", "participant", aggregate="mean")
    assert res.levels == ("baseline", "cautious", "our-method")
    with pytest.raises(ValueError, match="line 2, column 'treatment': unknown treatment"):
        read_table(path, "trials", treatments=("Standard", "Learned", "Conservative"))


def test_read_long_table(tmp_path):
    path = tmp_path / "long.csv"
    path.write_text("subj,cond,score,extra\n1,a,3.5,x\n1,b,4,y\n2,a,2,z\n2,b,5.5,w\n3,a,1,q\n3,b,2.5,r\n")
    data = read_table(path, "long", dv="score", within="cond", subject="subj")
    res = rm_anova(data, "score", "cond", "subj")
    assert res.n_subjects == 3 and res.df1 == 1
    assert res.p == pytest.approx(stats.ttest_rel([3.5, 2, 1], [4, 5.5, 2.5]).pvalue)


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
    import json
    from mutual.study.stats import pairwise_comparisons
    res = rm_anova(pairwise, "Scores", "Drug", "Subject")
    rows = pairwise_comparisons(res, as_records=True)
    assert json.loads(json.dumps(rows)) == rows and len(rows) == 3
    ab = next(r for r in rows if (r["A"], r["B"]) == ("A", "B"))
    assert ab["p_tukey"] == pytest.approx(0.273106, abs=2e-6) and ab["p_t"] == pytest.approx(0.18598346, rel=1e-7)
    assert ab["df"] == 10 and ab["diff"] == pytest.approx(res.means["A"] - res.means["B"])
