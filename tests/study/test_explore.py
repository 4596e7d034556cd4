"""The Explore views of notebook 04: plain functions returning figures whose content follows the inputs;
bad inputs (a table)."""

import numpy as np
import pytest
from matplotlib.collections import PathCollection
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from mutual.study import explore

from helpers.study import case_id, resolve


def _bar_heights(ax):
    return [p.get_height() for p in ax.patches if isinstance(p, Rectangle) and p.get_width() < 1.5]


def test_cohort_view_follows_noise_and_mix():
    base = explore.cohort_view(trial_seconds=10.0, n_scenes=20)
    assert isinstance(base, Figure) and "SIMULATED" in base._suptitle.get_text()
    left, right = base.axes
    assert "F(2, " in left.get_title() and "false positives per trial" in left.get_ylabel()
    assert "95% CI" in right.get_ylabel()
    noisy = explore.cohort_view(noise=0.25, trial_seconds=10.0, n_scenes=20)
    assert not np.allclose(_bar_heights(base.axes[0]), _bar_heights(noisy.axes[0]))
    smaller = explore.cohort_view(n_standard=1, n_conservative=1, n_gradual=2, n_agile=0, trial_seconds=10.0, n_scenes=20)
    assert "4 recruits, 4 analysed" in smaller._suptitle.get_text()
    assert "F(2, 6)" in smaller.axes[0].get_title()


def test_cohort_view_says_when_no_analysis_is_possible():
    fig = explore.cohort_view(n_standard=0, n_conservative=0, n_gradual=1, n_agile=2, trial_seconds=5.0, n_scenes=20)
    assert "no analysis possible" in fig._suptitle.get_text()
    assert any("need at least 2 subjects" in t.get_text() or "excluded" in t.get_text() for t in fig.axes[0].texts)


def test_misalignment_view_follows_the_level():
    def crosses(fig):
        return sum(len(c.get_offsets()) for c in fig.axes[1].collections if isinstance(c, PathCollection))
    at_mu = explore.misalignment_view(k=0.0)
    above = explore.misalignment_view(k=2.0)
    assert crosses(at_mu) > crosses(above)
    assert "alpha = mu + 2 sigma" in above.axes[1].get_title()
    assert "SIMULATED" in at_mu._suptitle.get_text()


CASES = [
    # --- the Explore views
    (explore.cohort_view, (), {"n_standard": -1}, ValueError, "n_standard must be an integer in 0..50"),
    (explore.cohort_view, (), {"n_standard": 1, "n_conservative": 0, "n_gradual": 0, "n_agile": 0}, ValueError,
     "at least 2 recruits"),
    (explore.cohort_view, (), {"noise": float("nan")}, ValueError, "noise must be a finite number in [0, 1]"),
    (explore.misalignment_view, (), {"w_supervisor": 0.9}, ValueError, "w_supervisor must be one of the library's"),
    (explore.misalignment_view, (), {"k": 10}, ValueError, "k must be a number in [-3, 5]"),
]


@pytest.mark.parametrize("function, args, kwargs, exception, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_is_named(function, args, kwargs, exception, phrase, tmp_path, functions):
    args = [resolve(a, tmp_path, functions) for a in args]
    with pytest.raises(exception) as info:
        function(*args, **kwargs)
    assert phrase in str(info.value)
