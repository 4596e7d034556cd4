"""Avoid value functions from hj-reachability (eq. 4.3) against the closed form, against trajectories of the
car under every sampled control, and against the head-on reach formula; bad inputs (a table)."""

import re

import numpy as np
import pytest

import mutual.supervision.reachability as reach
from mutual.supervision.dubins import avoid_value_closed_form, dubins_step, keep_out_margin, unsafe_reach
from mutual.supervision.reachability import (GridSpec, QUICK_GRID, SolverSpec, avoid_value_function,
                                             unsafe_set_contains, value_drift, value_library)

from helpers.supervision import GRID, case_id, grid_states


W_MAXES = 0.25 * np.arange(1, 13)
RADIUS = 1.0


@pytest.mark.parametrize("w_max", [0.5, 1.0, 2.0])
def test_numerical_value_matches_closed_form(library, w_max):
    vf = library[library.index_of(w_max)]
    exact = avoid_value_closed_form(grid_states(QUICK_GRID), w_max, RADIUS).reshape(QUICK_GRID.shape)
    dx = QUICK_GRID.spacings[0]
    near = np.abs(exact) < 2 * dx
    err = np.abs(vf.values - exact)[near]
    # first-order scheme: a fifth of a cell on average; the head-on ridge (a kink) is smoothed by ~a cell
    assert err.mean() < 0.2 * dx
    assert err.max() < 1.5 * dx
    assert np.mean((vf.values < 0) != (exact < 0)) < 0.005


def test_nesting_smaller_w_max_larger_unsafe_set_and_keep_out_inside(library):
    for slow, fast in zip(library.members[:-1], library.members[1:]):
        assert unsafe_set_contains(slow, fast)
        assert (slow.values < 0).sum() >= (fast.values < 0).sum()
        assert np.all(slow.values <= fast.values + 0.1 * QUICK_GRID.spacings[0])
    counts = [(vf.values < 0).sum() for vf in library]
    assert counts[0] > 1.5 * counts[-1]
    keep_out = keep_out_margin(grid_states(QUICK_GRID), RADIUS).reshape(QUICK_GRID.shape) < 0
    for vf in library:
        assert np.all(vf.values[keep_out] < 0)


def test_safe_control_keeps_states_just_outside_the_unsafe_set_out_of_k(library):
    vf = library[library.index_of(1.0)]
    rng = np.random.default_rng(2)
    cand = np.column_stack([rng.uniform(-6, 6, (4000, 2)), rng.uniform(-np.pi, np.pi, 4000)])
    exact = avoid_value_closed_form(cand, 1.0, RADIUS)
    start = cand[(exact > 0.3) & (exact < 0.5)][:200]
    assert len(start) > 50
    s, closest = start, keep_out_margin(start, RADIUS)
    for _ in range(400):  # 8 s, more than a full turn
        s = dubins_step(s, vf.safe_control(s), 0.02)
        closest = np.minimum(closest, keep_out_margin(s, RADIUS))
    assert closest.min() > 0


def test_no_sampled_control_escapes_from_well_inside(library):
    rng = np.random.default_rng(3)
    cand = np.column_stack([rng.uniform(-4, 4, (4000, 2)), rng.uniform(-np.pi, np.pi, 4000)])
    inside = cand[(avoid_value_closed_form(cand, 1.0, RADIUS) < -0.5) & (keep_out_margin(cand, RADIUS) > 0)][:40]
    assert library[library.index_of(1.0)].interp(inside).max() < 0
    controls = np.repeat(rng.uniform(-1, 1, size=(30, 10)), 40, axis=1)
    controls[:2] = [[1.0], [-1.0]]  # the hard turns
    n, k = len(inside), len(controls)
    s = np.repeat(inside, k, axis=0)
    u = np.tile(controls, (n, 1))
    closest = keep_out_margin(s, RADIUS)
    for step in range(u.shape[1]):
        s = dubins_step(s, u[:, step], 0.01)
        closest = np.minimum(closest, keep_out_margin(s, RADIUS))
    assert np.all(closest < 0)


def test_disturbance_enlarges_the_unsafe_set(cache):
    spec = GridSpec(8.0, (21, 21, 12))
    calm = value_library([1.0], RADIUS, spec, progress=False)[0]
    windy = value_library([1.0], RADIUS, spec, d_max=0.5, progress=False)[0]
    assert unsafe_set_contains(windy, calm)
    assert (windy.values < 0).sum() > (calm.values < 0).sum()


def test_vmap_batch_matches_loop(cache):
    spec = GridSpec(8.0, (21, 21, 12))
    loop = value_library([1.0, 2.0], RADIUS, spec, cache=False, progress=False)
    batched = value_library([1.0, 2.0], RADIUS, spec, batch="vmap", cache=False, progress=False)
    for a, b in zip(loop, batched):
        # the batch steps every member until the slowest converges: equal up to the tolerance
        assert np.max(np.abs(a.values - b.values)) < 5 * SolverSpec().tolerance


@pytest.mark.parametrize("kwargs, match", [
    (dict(w_maxes=[]), "w_maxes"), (dict(w_maxes=[1.0, -1.0]), "w_maxes"), (dict(w_maxes=[1.0, 1.0]), "repeat"),
    (dict(w_maxes=[np.nan]), "w_maxes"), (dict(obstacle_radius=0.0), "obstacle_radius"),
    (dict(d_max=-0.1), "d_max"), (dict(batch="gpu"), "batch"),
    (dict(w_maxes=[0.05]), "half_width"), (dict(grid_spec=(101, 101, 64)), "GridSpec"),
])
def test_bad_library_inputs_raise(kwargs, match):
    args = dict(w_maxes=[1.0], obstacle_radius=RADIUS, grid_spec=QUICK_GRID, progress=False) | kwargs
    with pytest.raises(ValueError, match=match):
        value_library(**args)


@pytest.mark.parametrize("w_max", [0.25, 1.0, 2.7])
def test_closed_form_library_is_the_oracle_at_every_node(w_max):
    spec = GridSpec(8.0, (33, 29, 16))
    vf = value_library([w_max], RADIUS, spec, method="closed-form")[0]
    assert vf.method == "closed-form" and vf.horizon == np.inf
    exact = avoid_value_closed_form(grid_states(spec), w_max, RADIUS).reshape(spec.shape)
    assert np.allclose(vf.values, exact, atol=1e-5)


def test_closed_form_refuses_a_disturbance(cache):
    with pytest.raises(ValueError, match="exact only without a disturbance"):
        value_library([1.0], RADIUS, QUICK_GRID, d_max=0.1, method="closed-form")
    with pytest.raises(ValueError, match="exact only without a disturbance"):
        reach.avoid_value_function(1.0, RADIUS, QUICK_GRID, d_max=0.1, method="closed-form")


def test_hj_and_closed_form_disagree_only_near_the_zero_level_set(library):
    exact = value_library(W_MAXES, RADIUS, QUICK_GRID, method="closed-form")
    dx = QUICK_GRID.spacings[0]
    for hj_vf, cf in zip(library, exact):
        flipped = (hj_vf.values < 0) != (cf.values < 0)
        assert flipped.mean() < 0.005
        # every disagreement on safety lies within 1.5 cells of the exact zero level set
        assert np.all(np.abs(cf.values[flipped]) < 1.5 * dx)


@pytest.mark.parametrize("w_max", [0.5, 1.0, 2.0])
def test_head_on_reach_matches_the_formula(library, w_max):
    dx = QUICK_GRID.spacings[0]
    exact = value_library([w_max], RADIUS, QUICK_GRID, method="closed-form")[0]
    # the closed form at the nodes, linearly interpolated along x: second-order accurate
    assert exact.head_on_reach() == pytest.approx(unsafe_reach(w_max, RADIUS), abs=0.05 * dx)
    assert library[library.index_of(w_max)].head_on_reach() == pytest.approx(unsafe_reach(w_max, RADIUS), abs=dx)


def test_drift_after_convergence_is_within_the_tolerance(cache):
    spec = GridSpec(8.0, (21, 21, 12))
    vf = value_library([1.0], RADIUS, spec, progress=False)[0]
    in_safe_set, everywhere = value_drift(vf, 2.0)
    assert 0 <= in_safe_set <= everywhere
    assert everywhere < 4 * SolverSpec().tolerance
    with pytest.raises(ValueError, match="method='hj'"):
        value_drift(value_library([1.0], RADIUS, spec, method="closed-form")[0], 1.0)


CASES = [
    (SolverSpec, (), {"max_time": -1.0}, ValueError, "max_time must be a positive finite"),
    (value_library, ("1.0", 1.0, GRID), {}, ValueError, "w_maxes must be a non-empty 1-D sequence"),
    (value_library, ([[1.0]], 1.0, GRID), {}, ValueError, "w_maxes must be a non-empty 1-D sequence"),
    (value_library, ([1.0], 1.0, GRID), {"method": "closed-form", "d_max": 0.2}, ValueError,
     "exact only without a disturbance"),
    (value_library, ([1.0], 1.0, GRID), {"method": "spline"}, ValueError, "method must be one of"),
    (value_library, ([1.0], 1.0, GRID), {"solver": "low"}, ValueError, "solver must be a SolverSpec"),
    (value_library, ([1.0], np.inf, GRID), {}, ValueError, "obstacle_radius must be a positive finite"),
    (avoid_value_function, (None, 1.0, GRID), {}, ValueError, "w_max must be a positive finite"),
]


@pytest.mark.parametrize("func, args, kwargs, error, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_raises_a_clear_error(func, args, kwargs, error, phrase):
    with pytest.raises(error, match=re.escape(phrase)):
        func(*args, **kwargs)
