"""Notebook 09's claim checks (``mutual.constraints.continuous.experiments``): a recording keeps exactly the
demonstrations that stay in the box, checked by brute force over the samples."""

import numpy as np

from mutual.constraints.continuous import Grid
from mutual.constraints.continuous.experiments import inside_box
from mutual.constraints.continuous.recordings import Recording


def test_inside_box_keeps_exactly_the_demonstrations_that_stay_in_the_box():
    rng = np.random.default_rng(0)
    grid = Grid.uniform([-1.0, -2.0], [1.0, 2.0], (5, 5), (False, False), ("x", "v"), ("m", "m/s"))
    states = tuple(rng.uniform(-1.3, 1.3, (7, 2)) * [1.0, 1.8] for _ in range(40))
    times = tuple(np.arange(7.0) for _ in states)
    controls = tuple(rng.normal(size=(7, 1)) for _ in states)
    recording = Recording(tuple(f"d{d}" for d in range(40)), times, states, controls)
    kept = inside_box(recording, grid)
    inside = [d for d, s in enumerate(states)
              if all(-1.0 <= x <= 1.0 and -2.0 <= v <= 2.0 for x, v in s)]
    assert 0 < len(inside) < 40
    assert kept.ids == tuple(f"d{d}" for d in inside) and kept.notes["left the box"] == 40 - len(inside)
    assert all(a is states[d] and c is controls[d] for a, c, d in zip(kept.states, kept.controls, inside))
    assert kept.lines is None and len(kept.times) == len(inside)
