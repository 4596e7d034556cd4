"""Intervals: the t interval is scipy's and the bootstrap is close on normal data; grouped summaries; bad
inputs (a table)."""

import numpy as np
import pytest
from scipy import stats

from mutual.cycle.intervals import mean_interval, summarise


def test_t_interval_is_scipys_and_bootstrap_is_close_on_normal_data():
    v = np.random.default_rng(0).normal(3.0, 2.0, 400)
    mean, low, high = mean_interval(v, 0.95, "t")
    lo, hi = stats.t.interval(0.95, len(v) - 1, loc=v.mean(), scale=stats.sem(v))
    assert (mean, low, high) == pytest.approx((v.mean(), lo, hi), rel=1e-12)
    _, blow, bhigh = mean_interval(v, 0.95, "bootstrap")
    assert blow == pytest.approx(lo, abs=0.05) and bhigh == pytest.approx(hi, abs=0.05)
    assert mean_interval([2.0, 2.0, 2.0]) == (2.0, 2.0, 2.0)
    assert np.all(np.isnan(mean_interval([np.nan])))


def test_summarise_groups():
    import pandas as pd
    df = pd.DataFrame({"g": [1, 1, 2, 2], "v": [0.0, 1.0, 5.0, 5.0]})
    out = summarise(df, "g", ["v"], method="t")
    assert out["v"].tolist() == [0.5, 5.0] and out["n"].tolist() == [2, 2]


CASES = [
    (mean_interval, ([1.0, 2.0],), {"method": "jackknife"}, ValueError, "method"),
    (mean_interval, ([1.0, 2.0],), {"level": 1.5}, ValueError, "level"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{c[0].__name__ if hasattr(c[0], '__name__') else 'call'}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase):
        fn(*args, **kwargs)
