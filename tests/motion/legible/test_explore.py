"""Notebook 05's Explore view follows its inputs; bad inputs (a table)."""

import numpy as np
import pytest

from mutual.motion.legible import explore as explore_legibility


def test_explore_view_follows_its_inputs():
    """The Explore figure's plotted data change with alpha and the goal layout."""
    def lines(fig):
        return [ln.get_xydata() for ln in fig.axes[0].get_lines()]

    base, more = explore_legibility.legibility_view(alpha=1.0), explore_legibility.legibility_view(alpha=4.0)
    assert not np.allclose(lines(base)[1], lines(more)[1])
    d = explore_legibility.legibility_paths(alpha=1.0)
    np.testing.assert_allclose(d["legible"][-1], [1.5, 0.5], atol=1e-9)     # the reference case
    assert d["belief_legible"][-1] > d["belief_predictable"][-1]
    five = explore_legibility.legibility_view(n_goals=5, true_goal=1, spread=8.0, goal_height=4.0)
    assert len(five.axes[0].collections) == 5                                  # one marker per goal
    assert len(five.axes[1].get_lines()) == 3                                  # two beliefs and the prior


CASES = [
    (explore_legibility.legibility_view, (), dict(alpha=-1.0), ValueError, "alpha must be a positive"),
    (explore_legibility.legibility_view, (), dict(n_goals=2, true_goal=5), ValueError, "true_goal must index"),
    (explore_legibility.legibility_view, (), dict(strictness=1.5), ValueError, "strictness must be"),
]


@pytest.mark.parametrize("fn,args,kwargs,error,phrase", CASES,
                         ids=[f"{i}-{c[0].__name__ if hasattr(c[0], '__name__') else c[0]}" for i, c in
                              enumerate(CASES)])
def test_bad_input_is_refused_with_a_clear_message(fn, args, kwargs, error, phrase):
    if error is None:
        out = fn(*args, **kwargs)
        assert np.all(np.isfinite(out.us))
        return
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value)
