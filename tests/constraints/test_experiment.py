"""Chapter 3's set-up: the layouts are fixed and layout four is the result's; bad layouts are named."""

import pytest

from mutual.constraints.experiment import LAYOUTS, chapter3
from mutual.constraints.gridworld import GRID_ACTIONS


def test_layouts_are_fixed_and_layout_four_is_the_result():
    four, first, second = chapter3(), chapter3("first"), chapter3("second")
    assert four.layout is LAYOUTS["four"] and four.layout.task_relevant == 4 and first.layout.task_relevant == 3
    assert [GRID_ACTIONS[a] for a in four.actions] == ["NW", "W", "SW"] and four.upper == first.upper
    assert LAYOUTS["first"].upper == ((2, 6), (4, 7), (6, 5)) and LAYOUTS["second"].upper == ((2, 6), (4, 7), (6, 6))
    assert first.grid.coords(first.bottom_middle) == (4, 0)
    north = GRID_ACTIONS.index("N")
    assert not first.truth[first.grid.state(6, 4), north] and first.truth[first.grid.state(6, 5), north]
    assert second.truth[second.grid.state(6, 4), north] and not second.truth[second.grid.state(6, 5), north]
    assert "layout four" in repr(four) and "layout first" in repr(first) and len(repr(four)) < 300


CASES = [
    (chapter3, (), dict(layout="third"), ValueError, "layout"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i:02d}-{case[0].__name__}" for i, case in enumerate(CASES)])
def test_bad_input_raises_a_clear_error(fn, args, kwargs, error, phrase):
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value), f"message {str(info.value)!r} should mention {phrase!r}"
