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
from mutual.study.stats import (cell_table, design_from_f_dofs, f_p_value, likert_vs_neutral, paired_t_holm,
                                recover_from_summary, rm_anova, tukey_from_summary, tukey_rm)

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
    res = rm_anova(pairwise, "Scores", "Subject", "Drug")
    assert (res.df_num, res.df_den, res.n_subjects) == (2, 20, 11)
    assert res.F == pytest.approx(1.450292398, rel=1e-8)
    assert res.p == pytest.approx(0.2581274727, rel=1e-8)
    assert res.mse == pytest.approx(2.590909091, rel=1e-8)
    assert res.epsilon_gg == pytest.approx(0.8574339089, rel=1e-8)
    # GG-corrected p: the F distribution with epsilon-scaled degrees of freedom
    assert res.p_gg == pytest.approx(stats.f.sf(res.F, 2 * res.epsilon_gg, 20 * res.epsilon_gg))
    assert res.p_gg > res.p


def test_tukey_rm_matches_pingouin(pairwise):
    tk = tukey_rm(rm_anova(pairwise, "Scores", "Subject", "Drug")).set_index(["A", "B"])["p"]
    assert tk[("A", "B")] == pytest.approx(0.273106, abs=2e-6)
    assert tk[("A", "C")] == pytest.approx(0.398489, abs=2e-6)
    assert tk[("B", "C")] == pytest.approx(0.962127, abs=2e-6)


def test_paired_t_holm_matches_pingouin_and_holm_by_hand(pairwise):
    res = paired_t_holm(rm_anova(pairwise, "Scores", "Subject", "Drug").cells).set_index(["A", "B"])
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
    res = rm_anova(pairwise, "Scores", "Subject", "Drug")
    assert res.F == pytest.approx(ss_a / (k - 1) / (ss_e / ((k - 1) * (n - 1))))


def test_recover_from_summary_round_trip(pairwise):
    res = rm_anova(pairwise, "Scores", "Subject", "Drug")
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
    res = rm_anova(df, "v", "s", "c")
    assert tukey_rm(res)["p"].iloc[0] == pytest.approx(stats.ttest_rel(y[:, 0], y[:, 1]).pvalue, rel=1e-6)
    assert res.epsilon_gg == pytest.approx(1.0)


def test_bad_input_raises(pairwise):
    with pytest.raises(ValueError, match="NaN"):
        rm_anova(pairwise.assign(Scores=pairwise["Scores"].where(pairwise.index != 3)), "Scores", "Subject", "Drug")
    with pytest.raises(ValueError, match="unbalanced"):
        rm_anova(pairwise.drop(index=5), "Scores", "Subject", "Drug")
    with pytest.raises(ValueError, match="duplicate"):
        rm_anova(pd.concat([pairwise, pairwise.iloc[[0]]]), "Scores", "Subject", "Drug")
    with pytest.raises(ValueError, match="missing columns"):
        cell_table(pairwise, "Score", "Subject", "Drug")
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
    (lambda d: d.drop(columns="trial"), "missing columns"),
    (lambda d: d.assign(value=d["value"].where(d.index != 7)), "NaN"),
    (lambda d: pd.concat([d, d.iloc[[4]]]), "duplicate"),
    (lambda d: d.assign(value=d["value"].where(d.index != 2, 9)), "Likert"),
    (lambda d: d.assign(treatment=d["treatment"].where(d.index != 0, "Reckless")), "unknown treatment"),
    (lambda d: d.assign(measure=d["measure"].where(d.index != 0, "joy")), "unknown measure"),
])
def test_bad_study_data_raises(questionnaire, corrupt, message):
    with pytest.raises(ValueError, match=message):
        validate_trials(corrupt(questionnaire))


def test_missing_cell_in_study_data_raises(questionnaire):
    trust = questionnaire[questionnaire["measure"] == "trust"]
    gone = trust[~((trust["participant"] == "P02") & (trust["treatment"] == "Learned"))]
    with pytest.raises(ValueError, match="unbalanced"):
        rm_anova(gone, "value", "participant", "treatment", aggregate="mean")
