"""The thesis's statistics re-derived from its published numbers: a summary round-trips through the
recovery, the thesis's F and p agree with its degrees of freedom, rounding ranges and Table 5.1's
ratios; bad inputs (a table)."""

import numpy as np
import pandas as pd
import pytest

from mutual.study.published import (design_from_f_dofs, f_p_value, recover_from_summary, rounding_range,
                                    table_5_1_ratios)
from mutual.study.stats import DegenerateDataError, rm_anova, tukey_rm

from helpers.study import case_id, resolve


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


THESIS_TABLE = pd.DataFrame({"safe_set": ["Standard", "Learned"], "interventions_in_safe_set": [397, 220],
                             "interventions": [440, 440], "predicted_fp_vs_standard": [1, 0.554],
                             "average_fp": [12.54, 7.31], "observed_fp_vs_standard": [1, 0.583]})


means3 = {"S": 12.54, "L": 7.31, "C": 4.68}


CASES = [
    (recover_from_summary, ({"S": 5.0, "L": 5.0, "C": 5.0}, 8.72, 2, 20), {}, DegenerateDataError, "all means are equal"),
    (f_p_value, (float("nan"), 2, 20), {}, ValueError, "F must be a finite number"),
    (f_p_value, (-1.0, 2, 20), {}, ValueError, "need F >= 0"),
    (design_from_f_dofs, (0, 20), {}, ValueError, "df_num must be an integer >= 1"),
    (design_from_f_dofs, (2, 21), {}, ValueError, "not a one-way repeated-measures design"),
    (recover_from_summary, (means3, 0.0, 2, 20), {}, ValueError, "F must be a positive finite number"),
    (recover_from_summary, ({"S": 1.0, "L": 2.0}, 8.72, 2, 20), {}, ValueError, "implies 3 levels, got 2 means"),
    (rounding_range, (means3, 8.72, 2, 20), {"decimals": -1}, ValueError, "decimals must be a whole number"),
    (table_5_1_ratios, (THESIS_TABLE.drop(columns="average_fp"),), {}, ValueError, "missing ['average_fp']"),
    (table_5_1_ratios, (THESIS_TABLE.assign(average_fp=[0.0, 1.0]),), {}, ValueError, "Standard row must have positive"),
]


@pytest.mark.parametrize("function, args, kwargs, exception, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_is_named(function, args, kwargs, exception, phrase, tmp_path, functions):
    args = [resolve(a, tmp_path, functions) for a in args]
    with pytest.raises(exception) as info:
        function(*args, **kwargs)
    assert phrase in str(info.value)
