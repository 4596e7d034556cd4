"""The obstacle search of the points model (``search``) against brute force over the demonstrations' path: the
largest obstacle at a centre, when its touching points enclose it, and the best centre to a fraction of the lattice."""

import numpy as np
import pytest

from mutual.constraints.continuous import Bound, Disk, Grid
from mutual.constraints.continuous import search


def test_the_largest_obstacle_at_a_centre_is_the_distance_to_the_path_by_brute_force():
    rng = np.random.default_rng(0)
    path = rng.uniform(-2, 2, (400, 2))
    centres = rng.uniform(-1, 1, (30, 2))
    kept = 0
    for kind in ("disk", "box"):
        for c in centres:
            found = search.largest_obstacles(kind, (0, 1), [c], path, 10.0, 0.0)
            d = path - c
            dist = np.hypot(d[:, 0], d[:, 1]) if kind == "disk" else np.abs(d).max(axis=1)
            size = dist.min()
            touching = d[dist <= size * (1 + search.TOUCH)]
            angles = np.sort(np.arctan2(touching[:, 1], touching[:, 0]))
            one_side = np.diff(np.r_[angles, angles[0] + 2 * np.pi]).max() >= np.pi
            assert (found == []) == one_side
            if found:
                kept += 1
                region = found[0]
                assert search.size_of(region) == pytest.approx(size, rel=1e-6)
                assert not region.inside(path).any() and region.inflated(1e-3 * size).inside(path).any()
    assert 5 <= kept < 2 * len(centres)          # both branches exercised


@pytest.mark.parametrize("angles, expected", [([0, 2.0, 4.0], True), ([0, 1.0, 2.0], False), ([0, np.pi], False),
                                              ([0.1, 1.7, 3.3, 4.9], True), ([1.0], False)])
def test_an_obstacle_is_enclosed_only_if_its_touching_points_are_not_in_one_half_plane(angles, expected):
    directions = np.c_[np.cos(angles), np.sin(angles)]
    assert search.enclosed(directions) is expected


def test_the_obstacle_search_finds_the_best_centre_to_a_fraction_of_its_lattice():
    """A score peaked at (0.33, -0.41), every centre admissible: the search ends within one refined step."""
    grid = Grid.uniform([-2, -2], [2, 2], [20, 20], [False, False], ("x", "y"), ("m", "m"))
    ring = np.c_[np.cos(np.linspace(0, 2 * np.pi, 200)), np.sin(np.linspace(0, 2 * np.pi, 200))] * 3.0
    target = np.array([0.33, -0.41])
    best, gain, tried = search.search_obstacle("disk", (0, 1), grid, ring, lambda regs: np.array(
        [-np.hypot(*(np.asarray(r.center) - target)) for r in regs]), largest=5.0)
    step = 4.0 / search.LATTICE / 2.5 ** search.REFINE[1]
    assert np.hypot(*(np.asarray(best.center) - target)) <= step and tried > search.REFINE[0] ** 2 * search.REFINE[1]


def test_a_disk_is_not_proposed_where_the_demonstrations_pass_on_one_side_only():
    """Paths along y = 0 only: every disk beside them touches them from one side, so none is a candidate."""
    grid = Grid.uniform([-2, -2], [2, 2], [20, 20], [False, False], ("x", "y"), ("m", "m"))
    path = np.c_[np.linspace(-2, 2, 100), np.zeros(100)]
    found = search.largest_obstacles("disk", (0, 1), search.lattice(grid.low, grid.high, 11), path, 1.0, 0.1)
    assert found == []
    both = np.vstack([path + [0, 0.5], path - [0, 0.5]])
    assert any(isinstance(d, Disk) for d in search.largest_obstacles("disk", (0, 1), [[0.0, 0.0]], both, 1.0, 0.1))
    assert Bound(0, "upper", 1.0).kind == "bound"
