"""Notebook 07's Explore views return figures whose content follows their inputs; bad inputs (a table)."""

import numpy as np
import pytest
from matplotlib.figure import Figure

from mutual.cycle import explore


def _image(fig):
    return np.asarray(fig.axes[0].images[0].get_array())


def _line(fig, i):
    return np.asarray(fig.axes[1].lines[i].get_ydata())


def test_discrete_view_follows_demonstrations_and_alpha():
    few, many = explore.discrete_view(n_demos=5, alpha=1.0), explore.discrete_view(n_demos=40, alpha=1.0)
    assert isinstance(few, Figure)
    assert not np.allclose(_image(few), _image(many))
    eager = explore.discrete_view(n_demos=40, alpha=0.05)
    np.testing.assert_allclose(_line(eager, 0), _line(many, 0))         # the plain robot does not depend on alpha
    assert not np.allclose(_line(eager, 1), _line(many, 1))             # the legible one does


def test_continuous_view_follows_the_level():
    low, high = explore.continuous_view(n_interventions=20, k=-1.0), explore.continuous_view(n_interventions=20, k=3.0)
    assert isinstance(low, Figure)
    heights = [[p.get_height() for p in fig.axes[1].patches] for fig in (low, high)]
    assert heights[0][0] > heights[1][0]                                 # learned robot: fewer false positives at k = 3
    assert heights[0][1:] == heights[1][1:]                              # standard and conservative unchanged


CASES = [
    (explore.discrete_view, (), {"n_demos": 0}, ValueError, "n_demos"),
    (explore.discrete_view, (), {"alpha": 0.0}, ValueError, "alpha"),
    (explore.continuous_view, (), {"n_interventions": 1}, ValueError, "n_interventions"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{c[0].__name__ if hasattr(c[0], '__name__') else 'call'}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase):
        fn(*args, **kwargs)
