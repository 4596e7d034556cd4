"""The naive baseline (``benchmark.naive``): the largest empty disk and box against brute force, and the side of
the tightest bound the trajectories ride."""

import numpy as np
import pytest

from mutual.constraints.continuous.benchmark import naive


def test_largest_empty_disk_matches_a_brute_force_search_over_centres():
    rng = np.random.default_rng(3)
    angle = rng.uniform(0, 2 * np.pi, 400)
    ring = np.c_[np.cos(angle), np.sin(angle)] * rng.uniform(0.6, 1.5, 400)[:, None] + [0.3, -0.2]
    disk = naive.largest_empty_disk(ring)
    g = np.linspace(-1.0, 1.0, 201)
    centres = np.stack(np.meshgrid(g + 0.3, g - 0.2), axis=-1).reshape(-1, 2)
    radius = np.min(np.linalg.norm(centres[:, None] - ring[None], axis=2), axis=1)
    assert disk.radius == pytest.approx(radius.max(), abs=0.01)
    assert np.hypot(*np.subtract(disk.center, (0.3, -0.2))) < 0.15


def test_largest_empty_box_matches_brute_force_over_raster_rectangles():
    rng = np.random.default_rng(5)
    points = rng.uniform(0, 1, size=(25, 2))
    R = 12
    box = naive.largest_empty_box(points, raster=R)
    cell = np.minimum((points - points.min(0)) / ((points.max(0) - points.min(0)) / R), R - 1).astype(int)
    full = np.zeros((R, R), dtype=bool)
    full[cell[:, 0], cell[:, 1]] = True
    best = max((i1 - i0) * (j1 - j0) for i0 in range(R) for i1 in range(i0 + 1, R + 1) for j0 in range(R)
               for j1 in range(j0 + 1, R + 1) if not full[i0:i1, j0:j1].any())
    size = (points.max(0) - points.min(0)) / R
    area = (box.high[0] - box.low[0]) * (box.high[1] - box.low[1])
    assert area == pytest.approx(best * size[0] * size[1])
    assert not box.inside(points).any()


def test_naive_pick_takes_the_side_the_trajectories_ride_and_ignores_angles_that_wrap():
    t = np.linspace(0, 1, 500)
    states = np.c_[np.linspace(-3, 3, 500), np.minimum(3 * t, 1.2) - 0.5]   # the second rides 0.7 for 60 %
    bound = naive.naive_pick(states, np.array([-3.2, -2.0]), np.array([3.2, 2.0]), [True, False])
    assert (bound.dim, bound.side) == (1, "upper") and bound.value == pytest.approx(0.7)
