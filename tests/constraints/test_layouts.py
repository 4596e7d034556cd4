"""The ground-truth layouts of chapter 3 (mutual.constraints.layouts): the rules the text fixes, checked on every
layout of the family and every width of the scan, and the set-up they give (truth mask built independently)."""

import numpy as np
import pytest

from mutual.constraints.chance import constraint_mask
from mutual.constraints.experiment import PSI_TRUTH, chapter3
from mutual.constraints.gridworld import GRID_ACTIONS
from mutual.constraints.layouts import (CHOSEN_LAYOUT, FAMILY_WIDTHS, Layout, MOVES_BUT_E, fits, layout_family,
                                        scaled_cell)


def test_the_family_follows_the_texts_counts():
    family = layout_family()
    assert family[0] is CHOSEN_LAYOUT and len(family) == 12
    assert sorted(len(lay.actions) for lay in family) == [1] * 4 + [2] * 4 + [3] * 4
    assert len({(lay.lower, lay.upper, lay.actions) for lay in family}) == 12
    for lay in family:
        assert lay.task_relevant == 4 and len(lay.upper) == 3 and "E" not in lay.actions
        assert set(lay.actions) <= set(MOVES_BUT_E)
        assert all(1 <= r <= 3 and 1 <= c <= 7 for c, r in lay.lower) and all(r >= 5 for _, r in lay.upper)
    assert layout_family() == family          # the draw is fixed


@pytest.mark.parametrize("width", FAMILY_WIDTHS)
def test_every_layout_keeps_its_cells_apart_and_in_their_halves(width):
    mid = (width - 1) // 2
    for lay in layout_family():
        setup = chapter3(lay, width=width)
        cells = [setup.grid.coords(s) for s in setup.states]
        assert len(set(cells)) == len(cells) == 4 + len(lay.lower)
        assert setup.grid.coords(setup.bottom_middle) == (mid, 0)
        assert all(0 < r < mid for _, r in (setup.grid.coords(s) for s in setup.lower))
        assert all(r > mid for _, r in (setup.grid.coords(s) for s in setup.upper))


def test_a_layout_off_its_half_does_not_fit():
    assert not fits(Layout("x", upper=((2, 5), (4, 7), (6, 5)), lower=((3, 3),), actions=("N", "S")), widths=(5,))
    assert not fits(Layout("x", upper=((2, 6), (3, 6), (6, 5)), actions=("N",)), widths=(7,))   # (2,6), (3,6) collide
    assert fits(CHOSEN_LAYOUT) and scaled_cell((3, 6), 7) == scaled_cell((2, 6), 7)


def test_the_set_up_forbids_exactly_the_layouts_truth():
    lay = layout_family()[1]
    setup = chapter3(lay, width=11, horizon=22)
    g = setup.grid
    cells = [(4, 0)] + list(lay.lower) + list(lay.upper)
    states = [g.state(*scaled_cell(c, 11)) for c in cells]
    expected = constraint_mask(g.mdp, states, PSI_TRUTH, [GRID_ACTIONS.index(a) for a in lay.actions])
    np.testing.assert_array_equal(setup.truth, expected)
    assert [g.coords(s) for s in setup.lower] == [scaled_cell(c, 11) for c in lay.lower]
    with pytest.raises(ValueError, match="layout"):
        chapter3("fourth")
