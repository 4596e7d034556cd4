"""The Explore section's views return figures whose content follows their inputs."""

import numpy as np
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
