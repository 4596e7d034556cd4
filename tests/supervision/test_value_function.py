"""Grids, value functions and libraries: interpolation is exact at the nodes, periodic in theta and NaN
outside, reproduces a trilinear function, and prints a short summary; bad inputs (a table)."""

import re

import numpy as np
import pytest

from mutual.supervision.reachability import GridSpec, QUICK_GRID, ValueFunction, unsafe_set_contains
from mutual.supervision.value_function import ValueLibrary

from helpers.supervision import GRID, case_id, grid_states, small_library, small_value_function


W_MAXES = 0.25 * np.arange(1, 13)
RADIUS = 1.0


def test_interpolation_is_exact_at_nodes_periodic_and_nan_outside(library):
    vf = library[3]
    nodes = grid_states(QUICK_GRID)[::97]
    assert np.allclose(vf.interp(nodes), vf.values.reshape(-1)[::97], atol=1e-6)
    shifted = nodes + np.array([0.0, 0.0, 2 * np.pi])
    assert np.allclose(vf.interp(shifted), vf.interp(nodes), atol=1e-5)
    outside = np.array([[8.5, 0.0, 0.0], [0.0, -9.0, 1.0]])
    assert np.all(np.isnan(vf.interp(outside)))
    assert np.all(vf.interp(outside, fill_value=np.inf) == np.inf)
    assert np.allclose(library.interp_all(nodes)[3], vf.interp(nodes))


def test_interpolation_reproduces_a_trilinear_function():
    spec = GridSpec(8.0, (21, 17, 12))
    s = grid_states(spec).reshape(spec.shape + (3,))
    values = 0.3 * s[..., 0] - 0.7 * s[..., 1] + 0.05 * s[..., 0] * s[..., 1] + np.cos(s[..., 2])
    vf = ValueFunction(1.0, RADIUS, spec, values)
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-8, 8, (50, 2)), np.zeros(50)])
    expected = 0.3 * pts[:, 0] - 0.7 * pts[:, 1] + 0.05 * pts[:, 0] * pts[:, 1] + 1.0
    assert np.allclose(vf.interp(pts), expected, atol=1e-4)


def test_value_function_and_library_print_short_summaries(library):
    for obj, words in [(library[3], ["w_max=1", "method='hj'", "41x41x24", "horizon="]),
                       (library, ["12 members", "w_max 0.25..3", "obstacle_radius=1"])]:
        text = repr(obj)
        assert len(text) < 250 and "array" not in text and "\n" not in text
        for word in words:
            assert word in text, (word, text)
    assert library[3].values.shape == QUICK_GRID.shape  # the data stays available


def _value_fn(**change):
    args = dict(w_max=1.0, obstacle_radius=1.0, grid_spec=GRID, values=np.zeros(GRID.shape)) | change
    return ValueFunction(**args)


CASES = [
    # grids, solver settings, value functions and libraries
    (GridSpec, (8.0, (41, 41, 4.5)), {}, ValueError, "shape must be three integers >= 5"),
    (GridSpec, (np.nan,), {}, ValueError, "half_width must be a positive finite"),
    (_value_fn, (), {"values": np.full(GRID.shape, np.nan)}, ValueError, "values contain"),
    (_value_fn, (), {"method": "exact"}, ValueError, "method must be one of"),
    (ValueLibrary, ([],), {}, ValueError, "members must be a non-empty list"),
    (lambda: ValueLibrary([small_value_function(), small_value_function()]), (), {}, ValueError, "members must have distinct w_max"),
    (lambda: small_library().index_of(np.nan), (), {}, ValueError, "w_max must be a finite number"),
    (lambda: small_library().index_of(0.6), (), {}, ValueError, "is not in the library"),
    (lambda: unsafe_set_contains(small_value_function(), "standard"), (), {}, ValueError,
     "must both be mutual.supervision.ValueFunction"),
    (lambda: small_value_function().theta_slice(0.0, resolution=1), (), {}, ValueError, "resolution must be an integer >= 2"),
]


@pytest.mark.parametrize("func, args, kwargs, error, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_raises_a_clear_error(func, args, kwargs, error, phrase):
    with pytest.raises(error, match=re.escape(phrase)):
        func(*args, **kwargs)
