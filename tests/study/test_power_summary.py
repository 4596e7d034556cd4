"""The simulated power table and its recommendations, from analysed cohorts; bad inputs (a table)."""

import numpy as np
import pandas as pd
import pytest

from mutual.study import power_summary as ps


def test_power_table_and_recommendations(inline):
    table = ps.power_table(inline, [3, 4, 5])
    assert set(table["n"]) == {3, 4, 5} and (table["cohorts"] == 4).all()
    assert ((table["ci_low"] <= table["power"]) & (table["power"] <= table["ci_high"])).all()
    gg = table[(table["test"] == "anova_gg") & (table["n"] == 5)].iloc[0]
    from mutual.study.rm_batch import rm_analyses
    assert gg["rejections"] == int(np.sum(rm_analyses(ps.analysed_outcomes(inline, 5)).p_gg < 0.05))
    rec = ps.recommendations(table)
    assert set(rec["test"]) == set(ps.KEY_TESTS) and (rec["largest n"] == 5).all()
    effect = ps.implied_effect(inline)
    assert effect["participants"] == 20 and 0 <= effect["eta2p"] < 1 and 0.5 - 1e-9 <= effect["epsilon"] <= 1 + 1e-9


TABLE = pd.DataFrame({"n": [6], "test": ["anova_gg"], "power": [0.5], "ci_low": [0.4], "ci_high": [0.6]})


CASES = [
    (ps.analysed_outcomes, ([], 5), {}, "cohorts must be a non-empty list"),
    (ps.analysed_outcomes, ([pd.DataFrame()], 1), {}, "n must be an integer >= 2"),
    (ps.power_table, ([], [5]), {}, "cohorts must be a non-empty list"),
    (ps.recommendations, (TABLE,), dict(tests=("nope",)), "no rows for test 'nope'"),
]


@pytest.mark.parametrize("fn, args, kwargs, phrase", CASES,
                         ids=[f"{getattr(c[0], '__name__', 'call')}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, phrase):
    with pytest.raises(ValueError) as err:
        fn(*args, **kwargs)
    assert phrase in str(err.value), f"{err.value!s} does not say {phrase!r}"
