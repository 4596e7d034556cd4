"""Chapter 3's set-up: the layouts are fixed and the first one is the result's; bad layouts are named."""

import pytest

from mutual.constraints.experiment import LAYOUTS, chapter3
from mutual.constraints.gridworld import GRID_ACTIONS


def test_layouts_are_fixed_and_the_first_one_is_the_result():
    first, second = chapter3("first"), chapter3("second")
    assert LAYOUTS["first"] == ((2, 6), (4, 7), (6, 5)) and LAYOUTS["second"] == ((2, 6), (4, 7), (6, 6))
    assert first.grid.coords(first.bottom_middle) == (4, 0)
    north = GRID_ACTIONS.index("N")
    assert not first.truth[first.grid.state(6, 4), north] and first.truth[first.grid.state(6, 5), north]
    assert second.truth[second.grid.state(6, 4), north] and not second.truth[second.grid.state(6, 5), north]
    assert "first layout" in repr(first) and len(repr(first)) < 300


CASES = [
    (chapter3, (), dict(layout="third"), ValueError, "layout"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i:02d}-{case[0].__name__}" for i, case in enumerate(CASES)])
def test_bad_input_raises_a_clear_error(fn, args, kwargs, error, phrase):
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value), f"message {str(info.value)!r} should mention {phrase!r}"
