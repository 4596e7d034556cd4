"""A library whose smallest w_max has an unsafe set wider than the grid is refused before any solve, with the
smallest w_max the grid holds; truth: bisection on the closed-form reach ``sqrt(2 (v / w) r + r^2)``."""

import re

import pytest

from mutual.supervision import GridSpec, value_library
from mutual.supervision.dubins import unsafe_reach

GRID = GridSpec(8.0, (41, 41, 24))


def _smallest_held(radius, speed, room):
    low, high = 1e-9, 1e9
    for _ in range(200):
        mid = (low * high) ** 0.5
        low, high = (mid, high) if unsafe_reach(mid, radius, speed) > room else (low, mid)
    return high


@pytest.mark.parametrize("w_maxes, radius, speed", [([0.01, 1.0], 1.0, 3.0), ([0.05, 0.5], 2.0, 1.0),
                                                    ([0.2], 0.5, 10.0)])
def test_a_library_wider_than_the_grid_names_the_smallest_w_max_it_holds(w_maxes, radius, speed):
    with pytest.raises(ValueError, match=r"grid_spec.half_width=8.0 is too small: the unsafe set of w_max=") as err:
        value_library(w_maxes, radius, GRID, speed=speed, progress=False, cache=False)
    shown = float(re.search(r"the smallest w_max it holds is ([0-9.e+-]+)", str(err.value)).group(1))
    assert shown == pytest.approx(_smallest_held(radius, speed, 8.0 - 4 * GRID.spacings[0]), rel=5e-3)          # shown to 3 digits


def test_an_obstacle_wider_than_the_grid_says_no_w_max_fits():
    with pytest.raises(ValueError, match="no w_max fits: the obstacle itself is wider than the grid"):
        value_library([1.0], 7.5, GRID, progress=False, cache=False)
