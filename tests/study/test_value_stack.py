"""The stacked value functions the teaming simulation evaluates in one call: each member's own interpolation,
exact members evaluated exactly, and values beyond a level's reach above the level."""

import numpy as np
import pytest

from mutual.study.cohort import study_value_functions
from mutual.study.teaming import _Stack
from mutual.supervision.dubins import unsafe_reach
from mutual.supervision.exact import exact_value_function
from mutual.supervision.reachability import value_library
from mutual.supervision.value_function import GridSpec

from helpers.study import member


def test_stacked_interpolation_equals_each_value_function(functions):
    library, conservative = functions
    fns = [library[0], library[4], conservative]
    which = np.array([2, 0, 1, 0])
    rng = np.random.default_rng(3)
    states = np.concatenate([rng.uniform(-10, 10, (4, 5, 7, 2)), rng.uniform(-7, 7, (4, 5, 7, 1))], axis=-1)
    stack = _Stack(fns, which, "test")
    got = stack.interp(states)
    slope = stack.interp(states, fill_value=0.0, derivative=True)
    for b, g in enumerate(which):
        flat = states[b].reshape(-1, 3)
        assert np.allclose(got[b].ravel(), fns[g].interp(flat, fill_value=np.inf), equal_nan=False)
        assert np.allclose(slope[b].ravel(), fns[g].interp_dtheta(flat, fill_value=0.0))


@pytest.mark.parametrize("exact", [False, True], ids=["grid", "exact"])
def test_values_lie_above_a_level_beyond_its_reach(functions, exact):
    """_Stack.reach (which pairs the simulation evaluates): farther out than reach(level), no state's value is
    below the level, on the grid (any heading) and in closed form; and the bound is not vacuous: at level 0 it
    is the unsafe set's head-on reach sqrt(2 R r + r^2) to within a grid cell's diagonal."""
    library, conservative = functions if not exact else study_value_functions(quick=True, exact=True)
    fns = [library[0], member(library, 1.0), library[len(library) - 1], conservative]
    which = np.repeat(np.arange(len(fns)), 50)
    stack = _Stack(fns, which, "test")
    rng = np.random.default_rng(7)
    level = rng.uniform(-1.0, 3.0, len(which))
    reach = stack.reach(level)
    w = stack.spec.half_width
    states = rng.uniform([-w, -w, -np.pi], [w, w, np.pi], (len(which), 400, 3))
    values = stack.interp(states)
    beyond = np.hypot(states[..., 0], states[..., 1]) > reach[:, None]
    assert beyond.mean() > 0.5 and np.all(values[beyond] >= level.repeat(400).reshape(beyond.shape)[beyond])
    at_zero = stack.reach(np.zeros(len(which)))[::50]
    expected = [unsafe_reach(f.w_max, f.obstacle_radius) for f in fns]
    assert np.all(at_zero >= np.array(expected) - 1e-9)
    assert np.all(at_zero <= np.array(expected) + (0 if exact else 2 * np.hypot(*stack.spec.spacings[:2])) + 1e-3)


GRID = GridSpec(8.0, (41, 41, 24))


def test_the_teaming_batch_evaluates_exact_functions_exactly():
    from mutual.study.value_stack import _Stack

    fns = [exact_value_function(w, r, GRID) for w, r in ((1.0, 1.0), (0.5, 2.0))]
    stack = _Stack(fns, np.array([0, 1, 1]), "team")
    rng = np.random.default_rng(4)
    states = np.concatenate([rng.uniform(-6, 6, (3, 5, 2, 2)), rng.uniform(-np.pi, np.pi, (3, 5, 2, 1))], axis=-1)
    got = stack.interp(states)
    for b, f in enumerate([fns[0], fns[1], fns[1]]):
        np.testing.assert_allclose(got[b].ravel(), f.interp(states[b].reshape(-1, 3), fill_value=np.inf), atol=1e-12)
    with pytest.raises(ValueError, match="all exact"):
        _Stack([fns[0], value_library([1.0], 1.0, GRID, method="closed-form")[0]], np.array([0, 1]), "team")
