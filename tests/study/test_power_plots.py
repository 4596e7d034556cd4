"""The power curves' figures and the Explore view: content that follows the inputs; bad inputs (a table)."""

import os

import numpy as np
import pandas as pd
import pytest

from mutual.study import power_plots


def test_explore_view_follows_its_inputs():
    import matplotlib.pyplot as plt
    opened_before = plt.get_fignums()                # other tests' figures are theirs to close
    small, large = power_plots.power_curve_view(f=0.2), power_plots.power_curve_view(f=0.6)
    y_small = small.axes[0].lines[0].get_ydata()
    y_large = large.axes[0].lines[0].get_ydata()
    assert np.all(y_large >= y_small) and y_large[9] > y_small[9] + 0.2
    labels = [t.get_text() for t in large.axes[0].get_legend().get_texts()]
    assert any(lbl.startswith("N = ") and "80%" in lbl for lbl in labels)
    assert os.environ.get("MPLBACKEND", "Agg")
    assert plt.get_fignums() == opened_before        # the view opened no pyplot figure


TABLE = pd.DataFrame({"n": [6], "test": ["anova_gg"], "power": [0.5], "ci_low": [0.4], "ci_high": [0.6]})


def _axes():
    from matplotlib.figure import Figure
    return Figure().add_subplot()


CASES = [
    (power_plots.power_curve_view, (), dict(n_max=2), "n_max must be at least 3"),
    (lambda: power_plots.plot_simulated_power(_axes(), TABLE, "nope", "x", "k"), (), {}, "no rows for test 'nope'"),
]


@pytest.mark.parametrize("fn, args, kwargs, phrase", CASES,
                         ids=[f"{getattr(c[0], '__name__', 'call')}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, phrase):
    with pytest.raises(ValueError) as err:
        fn(*args, **kwargs)
    assert phrase in str(err.value), f"{err.value!s} does not say {phrase!r}"
