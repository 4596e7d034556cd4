"""Repeated-measures statistics (section 5.3.1) on data at the edges of float64: a huge value in one level
leaves the other pairs' tests alone, averages of huge values do not overflow, and integers that differ only
beyond a double's digits are refused with that reason. Truths: scipy's paired t-test on each pair alone
(in units where it does not overflow), exact rational means, and the statistics' scale invariance."""

from fractions import Fraction

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from mutual.cli import main
from mutual.study import paired_t_holm, rm_anova
from mutual.study.stats import holm

RNG = np.random.default_rng(1)
N, LEVELS = 6, ["a", "b", "c"]
BASE = pd.DataFrame({"s": np.repeat([f"S{i}" for i in range(N)], 3), "c": np.tile(LEVELS, N),
                     "v": (10 + RNG.normal(size=3 * N)).round(3)})


def _with(**cells):
    """BASE with some cells replaced: ``S0_a=3e161``."""
    data = BASE.copy()
    for name, value in cells.items():
        subject, level = name.split("_")
        data.loc[(data["s"] == subject) & (data["c"] == level), "v"] = value
    return data


def _pair_truth(data, a, b, unit):
    """scipy's paired t-test of levels a and b alone, the data in ``unit`` (where its squares stay finite)."""
    wide = data.pivot(index="s", columns="c", values="v")
    return stats.ttest_rel(wide[a] / unit, wide[b] / unit).pvalue


@pytest.mark.parametrize("huge", [3e161, -3e161, 1e200, 1.7e308])
def test_a_huge_value_leaves_the_other_pairs_alone(huge):
    data = _with(S0_a=huge)
    table = paired_t_holm(rm_anova(data, "v", "c", "s")).set_index(["A", "B"])
    unit = abs(huge) / 1e10                                     # the outlier's pairs in units where 1e20 is the top square
    truth = {("a", "b"): _pair_truth(data, "a", "b", unit), ("a", "c"): _pair_truth(data, "a", "c", unit),
             ("b", "c"): _pair_truth(data, "b", "c", 1.0)}
    for pair, p in truth.items():
        assert table.loc[pair, "p"] == pytest.approx(p, rel=1e-9), pair
    assert np.allclose(table["p_holm"], holm(np.array(list(truth.values()))), rtol=1e-9)
    assert table.loc[("b", "c"), "p"] == pytest.approx(_pair_truth(BASE, "b", "c", 1.0), rel=1e-12)


@pytest.mark.parametrize("huge", [1.7e308, 1e308, -1.7e308])
def test_means_of_huge_values_do_not_overflow(huge):
    """Two rows per cell averaged: the cell of two huge values is their exact mean, and F is what the same data
    give in units 2^-10 smaller (F is scale-free; there nothing overflows)."""
    data = pd.concat([_with(S0_a=huge, S1_b=huge), _with(S0_a=huge / 2, S1_b=huge)], ignore_index=True)
    anova = rm_anova(data, "v", "c", "s", aggregate="mean")
    exact = (Fraction(huge) + Fraction(huge / 2)) / 2
    assert anova.cells.loc["S0", "a"] == float(exact) and anova.cells.loc["S1", "b"] == huge
    scaled = rm_anova(data.assign(v=np.ldexp(data["v"], -10)), "v", "c", "s", aggregate="mean")
    assert anova.F == pytest.approx(scaled.F, rel=1e-12) and anova.p == pytest.approx(scaled.p, rel=1e-12)


def test_integers_beyond_a_doubles_digits_are_refused_with_that_reason():
    big = BASE.assign(v=[2 ** 53 + int(k) for k in RNG.integers(0, 100, 3 * N)])
    with pytest.raises(ValueError, match="differ only beyond the 15-17 significant digits of a double"):
        rm_anova(big.astype({"v": object}), "v", "c", "s")
    with pytest.raises(ValueError, match="differ only beyond the 15-17 significant digits of a double"):
        rm_anova(big, "v", "c", "s")
    shifted = rm_anova(big.assign(v=big["v"] - 2 ** 53), "v", "c", "s")       # what the message says to do
    assert np.isfinite(shifted.F)


def test_the_command_line_refuses_them_naming_two_lines(tmp_path, capsys):
    path = tmp_path / "big.csv"
    values = [2 ** 53 + int(k) for k in RNG.integers(0, 100, 3 * N)]
    BASE.assign(v=values).to_csv(path, index=False)
    status = main(["study", "anova", str(path), "--dv", "v", "--within", "c", "--subject", "s", "--out",
                   str(tmp_path / "out"), "--no-progress"])
    err = capsys.readouterr().err
    assert status == 2 and "big.csv, line" in err and "(line" in err and "beyond the 15-17 significant digits" in err
    assert "does not vary" not in err


def test_values_that_vary_only_below_rounding_say_so():
    data = BASE.assign(v=1e300 + BASE.index % 2 * 1e286)      # apart by 1e-14 of their size: representable, not real
    with pytest.raises(ValueError, match="differ within subjects by less than 1e-13 of the largest"):
        rm_anova(data, "v", "c", "s")
