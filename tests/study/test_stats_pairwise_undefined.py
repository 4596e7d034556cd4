"""Pairs of levels whose paired differences are constant: their paired t is undefined (0/0 or infinite), the
other pairs are tested and Holm-corrected among themselves, and Tukey's q (pooled error term) stays defined.
Truth: scipy's ``ttest_rel`` pair by pair and statsmodels' Holm over the defined pairs; a drawing's lines
counted for the subjects drawn."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from scipy import stats  # noqa: E402
from statsmodels.stats.multitest import multipletests  # noqa: E402

from mutual.study import (MAX_SUBJECT_LINES, DegenerateDataError, paired_t_holm, pairwise_comparisons,  # noqa: E402
                          plot_condition_means, rm_anova)

# (subject x level table, the pairs without a t, a fragment of the first one's reason)
CASES = [
    ([[1, 4, 2], [2, 5, 7], [3, 6, 1]], [("a", "b")], "the same for every subject (-3)"),
    ([[1, 1, 2], [2, 2, 7], [3, 3, 1]], [("a", "b")], "identical for every subject"),
    ([[1, 4, 7], [2, 5, 8], [3, 6, 1]], [("a", "b")], "the same for every subject (-3)"),
    ([[1, 4, 7], [5, 8, 11], [2, 5, 9]], [("a", "b")], "the same for every subject (-3)"),
    ([[1, 2, 3], [5, 6, 7], [2, 3, 5]], [("a", "b")], "the same for every subject (-1)"),
]


def _anova(table):
    wide = np.array(table, dtype=float)
    rows = [(f"s{i}", level, wide[i, j]) for i in range(len(wide)) for j, level in enumerate("abc"[:wide.shape[1]])]
    return rm_anova(pd.DataFrame(rows, columns=["s", "c", "v"]), "v", "c", "s")


@pytest.mark.parametrize("table, pairs, reason", CASES)
def test_constant_differences_leave_that_pair_untested_and_the_others_as_scipy(table, pairs, reason):
    anova = _anova(table)
    with pytest.raises(DegenerateDataError, match=r"levels 'a' and 'b': the paired differences are"):
        paired_t_holm(anova)
    out = paired_t_holm(anova, undefined="leave").set_index(["A", "B"])
    assert list(out.attrs["undefined"]) == pairs and reason in out.attrs["undefined"][pairs[0]]
    assert "paired t statistic is undefined (zero variance)" in out.attrs["undefined"][pairs[0]]
    y = anova.cells.to_numpy()
    defined = [(a, b) for a, b in out.index if (a, b) not in pairs]
    for a, b in pairs:
        assert np.isnan(out.loc[(a, b), ["t", "p", "p_holm"]].to_numpy(dtype=float)).all()
    p = [stats.ttest_rel(y[:, "abc".index(a)], y[:, "abc".index(b)]).pvalue for a, b in defined]
    assert out.loc[defined, "p"].to_numpy() == pytest.approx(p, rel=1e-12)
    assert out.loc[defined, "p_holm"].to_numpy() == pytest.approx(multipletests(p, method="holm")[1], rel=1e-12)
    table = pairwise_comparisons(anova, undefined="leave")
    assert table["q"].notna().all() and table["p_tukey"].between(0, 1).all()
    assert table.attrs["undefined"] == out.attrs["undefined"]


@pytest.mark.parametrize("undefined", ["skip", None, "Leave"])
def test_an_unknown_choice_for_undefined_pairs_is_refused(undefined):
    with pytest.raises(ValueError, match="undefined must be 'raise' or 'leave'"):
        paired_t_holm(_anova(CASES[0][0]), undefined=undefined)


@pytest.mark.parametrize("subjects, lines", [(3, 3), (MAX_SUBJECT_LINES, MAX_SUBJECT_LINES), (MAX_SUBJECT_LINES + 1, 0),
                                             (5000, 0)])
def test_subjects_are_drawn_as_lines_up_to_a_readable_number(subjects, lines):
    rng = np.random.default_rng(subjects)
    anova = _anova(rng.normal(size=(subjects, 3)) + [0, 1, 2])
    fig, ax = plt.subplots()
    plot_condition_means(ax, anova)
    grey = [line for line in ax.lines if line.get_color() == "0.75"]
    plt.close(fig)
    assert len(grey) == lines
