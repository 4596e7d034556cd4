"""The Explore view of notebook 03: a plain function returning a Figure whose content follows its inputs
(raising alpha avoids more of the same interventions, the avoided fraction follows the noise model);
bad inputs (a table). Its speed is measured in `make bench`, not here."""

import re

import numpy as np
import pytest
from matplotlib.collections import PathCollection
from matplotlib.figure import Figure
from scipy import stats

from mutual.supervision import explore
from mutual.supervision.dubins import rotate_to_heading

from helpers.supervision import case_id


def _scatter_points(fig):
    """The plotted intervention markers of the left panel, as (avoided, not avoided) arrays."""
    left = fig.axes[0]
    filled, hollow = [c.get_offsets() for c in left.collections if isinstance(c, PathCollection)]
    return np.asarray(filled), np.asarray(hollow)


def test_view_returns_a_figure_that_says_simulated():
    fig = explore.safe_set_view()
    assert isinstance(fig, Figure)
    assert "Simulated" in fig.get_suptitle() or "simulated" in fig.get_suptitle()
    for ax in fig.axes[:2]:
        assert ax.get_xlabel() and ax.get_ylabel()
    assert "(m)" in fig.axes[0].get_xlabel()


def test_raising_alpha_avoids_more_of_the_same_interventions():
    low, high = explore.safe_set_summary(alpha=0.4), explore.safe_set_summary(alpha=1.0)
    assert np.array_equal(low["states"], high["states"])  # same supervisor, same seed
    assert high["avoided"].sum() > low["avoided"].sum()
    assert np.all(high["avoided"][low["avoided"]])  # nested: what alpha = 0.4 avoids, alpha = 1 avoids too
    # the plot shows exactly that split, at the interventions rotated to heading 0
    filled, hollow = _scatter_points(explore.safe_set_view(alpha=1.0))
    canon = rotate_to_heading(high["states"], 0.0)
    assert np.allclose(filled, canon[high["avoided"], :2]) and np.allclose(hollow, canon[~high["avoided"], :2])


def test_the_avoided_fraction_follows_the_noise_model():
    d = explore.safe_set_summary(mu=0.5, sigma=0.03, alpha=0.5 + 2 * 0.03, n_interventions=400)
    fit = d["fit"]
    assert fit.w_max == 0.75  # a precise supervisor's member is recovered from 400 interventions
    assert abs(d["avoided"].mean() - stats.norm.cdf(2.0)) < 0.03
    assert abs(d["expected"] - stats.norm.cdf((d["alpha"] - fit.mu) / fit.sigma)) < 1e-12
    # alpha = mu* + 2 sigma* of the fit avoids about Phi(2) of them, whichever member was fitted (Sec. 4.5)
    noisy = explore.safe_set_summary(mu=0.5, sigma=0.1, n_interventions=400)
    level = noisy["fit"].level(2.0)
    again = explore.safe_set_summary(mu=0.5, sigma=0.1, alpha=level, n_interventions=400)
    assert abs(again["avoided"].mean() - stats.norm.cdf(2.0)) < 0.03


def test_the_supervisor_parameters_change_what_is_plotted():
    base = explore.safe_set_summary()
    slower = explore.safe_set_summary(w_max=0.5)
    farther = explore.safe_set_summary(mu=1.0)
    # interventions move out with a slower mental model and with a larger margin
    assert np.hypot(*slower["states"][:, :2].T).mean() > np.hypot(*base["states"][:, :2].T).mean()
    assert np.hypot(*farther["states"][:, :2].T).mean() > np.hypot(*base["states"][:, :2].T).mean()
    precise = [explore.safe_set_summary(w_max=w, sigma=0.03)["fit"].w_max for w in (0.5, 0.75, 1.5)]
    assert precise == [0.5, 0.75, 1.5]
    a, b = explore.safe_set_view(), explore.safe_set_view(w_max=0.5)
    assert not np.array_equal(_scatter_points(a)[0], _scatter_points(b)[0])


CASES = [
    # the Explore view
    (explore.safe_set_view, (), {"w_max": 5.0}, ValueError, "w_max must be a number in [0.25, 3]"),
    (explore.safe_set_view, (), {"n_interventions": 2.5}, ValueError, "n_interventions must be an integer"),
]


@pytest.mark.parametrize("func, args, kwargs, error, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_raises_a_clear_error(func, args, kwargs, error, phrase):
    with pytest.raises(error, match=re.escape(phrase)):
        func(*args, **kwargs)
