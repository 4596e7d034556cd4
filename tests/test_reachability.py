"""Avoid value functions from hj-reachability against the closed form, trajectories and the cache."""

import warnings

import numpy as np
import pytest

import mutual.supervision.reachability as reach
from mutual.supervision import value_cache
from mutual.supervision.dubins import avoid_value_closed_form, dubins_step, keep_out_margin, unsafe_reach
from mutual.supervision.reachability import (QUICK_GRID, GridSpec, SolverSpec, ValueFunction, unsafe_set_contains,
                                             value_drift, value_library)
from mutual.supervision.value_cache import CacheWarning

W_MAXES = 0.25 * np.arange(1, 13)
RADIUS = 1.0


@pytest.fixture(scope="module")
def cache(tmp_path_factory, monkeypatch_module):
    folder = tmp_path_factory.getbasetemp() / "reachability-cache"
    monkeypatch_module.setenv("MUTUAL_CACHE_DIR", str(folder))
    return folder


@pytest.fixture(scope="module")
def monkeypatch_module():
    with pytest.MonkeyPatch.context() as mp:
        yield mp


@pytest.fixture(scope="module")
def library(cache):
    return value_library(W_MAXES, RADIUS, QUICK_GRID, progress=False)


def _grid_states(spec):
    xs, ys, ts = spec.coordinate_vectors
    return np.stack(np.meshgrid(xs, ys, ts, indexing="ij"), -1).reshape(-1, 3)


@pytest.mark.parametrize("w_max", [0.5, 1.0, 2.0])
def test_numerical_value_matches_closed_form(library, w_max):
    vf = library[library.index_of(w_max)]
    exact = avoid_value_closed_form(_grid_states(QUICK_GRID), w_max, RADIUS).reshape(QUICK_GRID.shape)
    dx = QUICK_GRID.spacings[0]
    near = np.abs(exact) < 2 * dx
    err = np.abs(vf.values - exact)[near]
    # first-order scheme: a fifth of a cell on average; the head-on ridge (a kink) is smoothed by ~a cell
    assert err.mean() < 0.2 * dx
    assert err.max() < 1.5 * dx
    assert np.mean((vf.values < 0) != (exact < 0)) < 0.005


def test_interpolation_is_exact_at_nodes_periodic_and_nan_outside(library):
    vf = library[3]
    nodes = _grid_states(QUICK_GRID)[::97]
    assert np.allclose(vf.interp(nodes), vf.values.reshape(-1)[::97], atol=1e-6)
    shifted = nodes + np.array([0.0, 0.0, 2 * np.pi])
    assert np.allclose(vf.interp(shifted), vf.interp(nodes), atol=1e-5)
    outside = np.array([[8.5, 0.0, 0.0], [0.0, -9.0, 1.0]])
    assert np.all(np.isnan(vf.interp(outside)))
    assert np.all(vf.interp(outside, fill_value=np.inf) == np.inf)
    assert np.allclose(library.interp_all(nodes)[3], vf.interp(nodes))


def test_interpolation_reproduces_a_trilinear_function():
    spec = GridSpec(8.0, (21, 17, 12))
    s = _grid_states(spec).reshape(spec.shape + (3,))
    values = 0.3 * s[..., 0] - 0.7 * s[..., 1] + 0.05 * s[..., 0] * s[..., 1] + np.cos(s[..., 2])
    vf = ValueFunction(1.0, RADIUS, spec, values)
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-8, 8, (50, 2)), np.zeros(50)])
    expected = 0.3 * pts[:, 0] - 0.7 * pts[:, 1] + 0.05 * pts[:, 0] * pts[:, 1] + 1.0
    assert np.allclose(vf.interp(pts), expected, atol=1e-4)


def test_nesting_smaller_w_max_larger_unsafe_set_and_keep_out_inside(library):
    for slow, fast in zip(library.members[:-1], library.members[1:]):
        assert unsafe_set_contains(slow, fast)
        assert (slow.values < 0).sum() >= (fast.values < 0).sum()
        assert np.all(slow.values <= fast.values + 0.1 * QUICK_GRID.spacings[0])
    counts = [(vf.values < 0).sum() for vf in library]
    assert counts[0] > 1.5 * counts[-1]
    keep_out = keep_out_margin(_grid_states(QUICK_GRID), RADIUS).reshape(QUICK_GRID.shape) < 0
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


def test_cache_serves_second_call_and_recomputes_on_any_key_change(cache, monkeypatch):
    spec = GridSpec(8.0, (21, 21, 12))
    calls = []
    real = reach._converge

    def counting(w_maxes, *args):
        calls.append(list(w_maxes))
        yield from real(w_maxes, *args)

    monkeypatch.setattr(reach, "_converge", counting)
    first = value_library([1.0, 2.0], RADIUS, spec, progress=False)
    second = value_library([1.0, 2.0], RADIUS, spec, progress=False)
    assert calls == [[1.0, 2.0]]
    assert np.array_equal(first[0].values, second[0].values)
    value_library([1.0, 3.0], RADIUS, spec, progress=False)
    assert calls[-1] == [3.0]
    changes = [dict(obstacle_radius=1.2), dict(grid_spec=GridSpec(8.0, (21, 21, 14))),
               dict(grid_spec=GridSpec(8.5, (21, 21, 12))), dict(solver=SolverSpec(accuracy="medium")),
               dict(solver=SolverSpec(tolerance=3e-3)), dict(speed=2.5), dict(d_max=0.2)]
    for change in changes:
        before = len(calls)
        value_library(**({"w_maxes": [1.0], "obstacle_radius": RADIUS, "grid_spec": spec, "progress": False}
                         | change))
        assert len(calls) == before + 1, change
    monkeypatch.setattr(reach, "_versions", lambda: {"jax": "0.0"})
    value_library([1.0], RADIUS, spec, progress=False)
    assert calls[-1] == [1.0] and len(calls) == 1 + 1 + len(changes) + 1


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


# ---------------------------------------------------------------------------- the closed-form method

@pytest.mark.parametrize("w_max", [0.25, 1.0, 2.7])
def test_closed_form_library_is_the_oracle_at_every_node(w_max):
    spec = GridSpec(8.0, (33, 29, 16))
    vf = value_library([w_max], RADIUS, spec, method="closed-form")[0]
    assert vf.method == "closed-form" and vf.horizon == np.inf
    exact = avoid_value_closed_form(_grid_states(spec), w_max, RADIUS).reshape(spec.shape)
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


# ---------------------------------------------------------------------------- short summaries (issue 11)

def test_value_function_and_library_print_short_summaries(library):
    for obj, words in [(library[3], ["w_max=1", "method='hj'", "41x41x24", "horizon="]),
                       (library, ["12 members", "w_max 0.25..3", "obstacle_radius=1"])]:
        text = repr(obj)
        assert len(text) < 250 and "array" not in text and "\n" not in text
        for word in words:
            assert word in text, (word, text)
    assert library[3].values.shape == QUICK_GRID.shape  # the data stays available


# ---------------------------------------------------------------------------- the cache heals (issue 13)

SMALL = GridSpec(8.0, (21, 21, 12))


@pytest.fixture
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("MUTUAL_CACHE_DIR", str(tmp_path))
    return tmp_path


def _reseal(path, fields):
    """Write ``fields`` to ``path`` with a checksum consistent with them (as a forger would)."""
    fields = dict(fields)
    fields["checksum"] = np.str_(value_cache._checksum(str(fields["key"]), fields["values"], float(fields["horizon"]),
                                                       str(fields["params"])))
    np.savez(path, **fields)


def _damage(path, how, other=None):
    data = path.read_bytes()
    if how == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif how == "garbage":
        path.write_bytes(np.random.default_rng(0).bytes(len(data)))
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "bit-flip":  # a valid zip whose values no longer match the checksum
        with np.load(path) as f:
            fields = {k: f[k] for k in f.files}
        fields["values"] = fields["values"].copy()
        fields["values"].flat[123] += 0.5
        np.savez(path, **fields)
    elif how == "foreign":  # a valid file of another member copied over this one
        path.write_bytes(other.read_bytes())
    elif how == "nan":  # NaN values with a checksum that matches them (a solver gone wrong)
        with np.load(path) as f:
            fields = {k: f[k] for k in f.files}
        fields["values"] = fields["values"].copy()
        fields["values"].flat[7] = np.nan
        _reseal(path, fields)
    elif how == "old-format":
        with np.load(path) as f:
            np.savez(path, values=f["values"], horizon=f["horizon"])
    else:
        raise AssertionError(how)


@pytest.mark.parametrize("how", ["truncated", "garbage", "empty", "bit-flip", "foreign", "nan", "old-format"])
def test_a_damaged_cache_file_warns_with_its_path_and_is_rebuilt(private_cache, how):
    fresh = value_library([1.0, 2.0], RADIUS, SMALL, progress=False)
    key = reach.cache_key(1.0, RADIUS, reach.SPEED, 0.0, SMALL, SolverSpec())
    path = value_cache.cache_file(key)
    other = value_cache.cache_file(reach.cache_key(2.0, RADIUS, reach.SPEED, 0.0, SMALL, SolverSpec()))
    assert path.exists() and other.exists()
    _damage(path, how, other)
    with pytest.warns(CacheWarning, match=str(path)):
        again = value_library([1.0, 2.0], RADIUS, SMALL, progress=False)
    assert np.array_equal(again[0].values, fresh[0].values)
    assert np.array_equal(again[1].values, fresh[1].values)
    # the file was rewritten and verifies: a third call is silent
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        third = value_library([1.0], RADIUS, SMALL, progress=False)
    assert np.array_equal(third[0].values, fresh[0].values)


def test_an_interrupted_build_keeps_its_finished_members(private_cache, monkeypatch):
    real = reach._converge
    computed = []

    def interrupted(w_maxes, *args):
        for item in real(w_maxes, *args):
            computed.append(item[0])
            yield item
            if len(computed) == 1:
                raise KeyboardInterrupt

    monkeypatch.setattr(reach, "_converge", interrupted)
    with pytest.raises(KeyboardInterrupt):
        value_library([1.0, 2.0, 3.0], RADIUS, SMALL, progress=False)
    saved = sorted(private_cache.glob("reachability/*.npz"))
    assert len(saved) == 1
    assert saved[0] == value_cache.cache_file(reach.cache_key(1.0, RADIUS, reach.SPEED, 0.0, SMALL, SolverSpec()))
    assert not list(private_cache.glob("reachability/.*"))  # no temporary files left behind
    monkeypatch.setattr(reach, "_converge", real)
    calls = []

    def counting(w_maxes, *args):
        calls.append(list(w_maxes))
        yield from real(w_maxes, *args)

    monkeypatch.setattr(reach, "_converge", counting)
    value_library([1.0, 2.0, 3.0], RADIUS, SMALL, progress=False)
    assert calls == [[2.0, 3.0]]
