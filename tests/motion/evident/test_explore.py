"""Notebook 06's Explore view changes with its inputs; bad inputs (a table)."""

import numpy as np
import pytest

from mutual.motion.evident import explore


def test_explore_view_changes_with_its_inputs():
    def data(fig):
        return [line.get_xydata().copy() for ax in fig.axes for line in ax.get_lines()]
    base = data(explore.evident_view(0.5, -2.0, 2.0, steps=20))
    moved = data(explore.evident_view(0.5, 2.0, -2.0, steps=20))
    other_alpha = data(explore.evident_view(1.5, -2.0, 2.0, steps=20))
    assert len(base) >= 6
    assert not all(np.array_equal(a, b) for a, b in zip(base, moved))
    assert not all(np.array_equal(a, b) for a, b in zip(base, other_alpha))
    with pytest.raises(ValueError, match="alpha"):
        explore.evident_view(0.0)


CASES = [
    (explore.evident_view, (-1.0,), {}, ValueError, "alpha must be positive"),
    (explore.evident_view, (0.5, np.nan), {}, ValueError, "hazard_x must be a finite number"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i}-{c[0].__name__}-{c[4][:24]}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase.replace("(", r"\(").replace(")", r"\)")):
        fn(*args, **kwargs)
