"""Benchmarks of chapter 4: the w_max value-function library, the supervisor fit, interpolation and
the Explore view. Every row names its baseline, the sizes, both times, the compile time and how
agreement was checked (bench/run.py computes the ratio = baseline seconds / seconds).

* Closed form vs HJ (issue 14): all 13 members of the exact closed-form library against the HJ
  solver's library (the thesis's method), cold, on the thesis's grid (the quick grid in --quick).
* HJ compiled once (``w_max`` traced) against hj-reachability's usual call, one ``hj.step`` with a
  concrete dynamics object per member (each member recompiles); same chunks, same stop rule.
* Warm: the library from the verified disk cache against unverified ``np.load`` of the same files.
* Fit: ``fit_supervisor`` (shared interpolation weights, vectorised eq. 4.8) against a per-member
  loop of ``ValueFunction.interp`` and numpy mean/variance.
* Interpolation: numpy trilinear against hj-reachability's ``Grid.interpolate`` (jit + vmap).
* vmap over members (the GPU path) against the loop, compiled.
* Explore view: latency of one slider move and of the first call (a target, no speed-up claim, no baseline).
"""

import io
import os
import tempfile
import time
import warnings
from contextlib import contextmanager

import hj_reachability as hj
import jax
import jax.numpy as jnp
import numpy as np

from mutual.constraints.complexity import best_time
from mutual.supervision import explore, fit as fit_module, reachability, value_cache
from mutual.dubins import DubinsCar
from mutual.supervision.fit import LibraryEdgeWarning, fit_supervisor
from mutual.supervision.reachability import (FULL_GRID, QUICK_GRID, SolverSpec, _initial_values, closed_form_agreement,
                                             value_library)
from mutual.supervision.supervisor import NoisySupervisor, collect_interventions

RADIUS = 1.0
W_MAXES = np.linspace(0.25, 3.0, 13)


def _shape(grid):
    return "x".join(map(str, grid.shape))


def _fresh_call_per_member(w_maxes, grid_spec, solver):
    """hj-reachability's usual call: hj.step with a concrete dynamics object per member (recompiles each)."""
    grid = grid_spec.build()
    settings = hj.SolverSettings.with_accuracy(solver.accuracy,
                                               hamiltonian_postprocessor=hj.solver.backwards_reachable_tube)
    out = []
    for w in w_maxes:
        values, t = _initial_values(grid_spec, RADIUS), 0.0
        while True:
            new = hj.step(settings, DubinsCar(float(w)), grid, t, values, t - solver.chunk_time, progress_bar=False)
            change = float(jnp.max(jnp.abs(new - values)))
            values, t = new, t - solver.chunk_time
            if change < solver.tolerance or -t >= solver.max_time:
                break
        out.append(np.asarray(values, dtype=np.float32))
    return out


@contextmanager
def _private_cache():
    """A temporary MUTUAL_CACHE_DIR, restored afterwards."""
    old = os.environ.get("MUTUAL_CACHE_DIR")
    with tempfile.TemporaryDirectory() as cache:
        os.environ["MUTUAL_CACHE_DIR"] = cache
        try:
            yield
        finally:
            if old is None:
                os.environ.pop("MUTUAL_CACHE_DIR", None)
            else:
                os.environ["MUTUAL_CACHE_DIR"] = old


def _clear_compiled():
    reachability._chunk_stepper.cache_clear()
    jax.clear_caches()


def _compile_seconds(grid, solver, batched=False, members=1):
    """Compile time of the chunk stepper: its first call minus a second, identical call."""
    _clear_compiled()
    stepper = reachability._chunk_stepper(grid, solver.accuracy, batched)
    values = _initial_values(grid, RADIUS)
    w = jnp.ones(members, dtype=jnp.float32) if batched else jnp.float32(1.0)
    if batched:
        values = jnp.broadcast_to(values, (members,) + values.shape)
    times = []
    for _ in range(2):
        start = time.perf_counter()
        stepper(w, 0.0, 3.0, values, 0.0, -solver.chunk_time).block_until_ready()
        times.append(time.perf_counter() - start)
    return max(times[0] - times[1], 0.0)


def run(quick=False):
    grid = QUICK_GRID if quick else FULL_GRID
    w_maxes = W_MAXES[::4] if quick else W_MAXES  # quick: 4 members, so that CI stays short
    solver = SolverSpec()
    members = f"{len(w_maxes)} members"
    rows = []
    with _private_cache():
        # --- HJ cold (the thesis's method) and the closed form on the same grid
        compile_s = _compile_seconds(grid, solver)
        _clear_compiled()
        start = time.perf_counter()
        hj_library = value_library(w_maxes, RADIUS, grid, solver, progress=False)
        hj_cold = time.perf_counter() - start
        start = time.perf_counter()
        value_library(w_maxes, RADIUS, grid, method="closed-form")
        closed = time.perf_counter() - start
        agreement = closed_form_agreement(hj_library)
        rows.append({
            "benchmark": f"value library, closed form ({members}, cold)", "case": f"{_shape(grid)} nodes, r = 1 m",
            "seconds": closed, "baseline": f"HJ solver library, cold (the thesis's method; incl. {compile_s:.1f} s "
                                          "compile)",
            "baseline_seconds": hj_cold, "compile_seconds": 0.0,
            "agree": f"differs from HJ at {agreement['sign_mismatch_fraction'].max():.2%} of nodes at most (sign of "
                     f"V), mean |dV| near V = 0 {agreement['mean_abs_error_cells'].max():.2f} cells",
            "target": "< 5 s cold (13 members, 101x101x64)", "met": None if quick else closed < 5})

        # --- HJ compiled once against one fresh hj.step compile per member (small grid: equal work twice)
        small = QUICK_GRID
        few = w_maxes[:2] if quick else w_maxes[::4]  # the per-member ratio needs no more
        small_compile = _compile_seconds(small, solver)
        _clear_compiled()
        start = time.perf_counter()
        ours = value_library(few, RADIUS, small, solver, cache=False, progress=False)
        ours_s = time.perf_counter() - start - small_compile
        _clear_compiled()
        start = time.perf_counter()
        theirs = _fresh_call_per_member(few, small, solver)
        fresh = time.perf_counter() - start
        gap = max(float(np.abs(a.values - b).max()) for a, b in zip(ours, theirs))
        rows.append({
            "benchmark": f"HJ library, compiled once ({len(few)} members, cold)",
            "case": f"{_shape(small)} nodes, w_max traced",
            "seconds": ours_s, "baseline": "hj.step with a concrete DubinsCar per member (one compile per member, "
                                           "included)",
            "baseline_seconds": fresh, "compile_seconds": small_compile,
            "agree": f"max |dV| = {gap:.1e} (same chunks and stop rule)", "target": "", "met": None})

        # --- warm: verified cache against unverified np.load of the same files
        warm = best_time(lambda: value_library(w_maxes, RADIUS, grid, solver, progress=False), 3)
        files = [value_cache.cache_file(reachability.cache_key(w, RADIUS, 3.0, 0.0, grid, solver)) for w in w_maxes]

        def raw_load():
            out = []
            for path in files:
                with np.load(path) as f:
                    out.append(f["values"])
            return out

        raw = best_time(raw_load, 3)
        same = all(np.array_equal(a, m.values) for a, m in zip(raw_load(), hj_library))
        rows.append({"benchmark": f"value library ({members}, warm)", "case": f"{_shape(grid)}, disk cache",
                     "seconds": warm, "baseline": "np.load of the same files, no key/checksum/NaN check",
                     "baseline_seconds": raw, "compile_seconds": 0.0,
                     "agree": f"identical arrays: {same}", "target": "< 1 s", "met": warm < 1})

        # --- the fit, vectorised against a per-member loop
        rng = np.random.default_rng(0)
        states = collect_interventions(NoisySupervisor(hj_library[1], 0.5, 0.05), 40, rng, 7.5)
        reference = hj_library[int(np.argmin(np.abs(w_maxes - 1.0)))]  # the member nearest the true robot
        for prior in ("mle", "map"):
            def fit_once(prior=prior):
                fit_module._conservative_members.cache_clear()  # MAP: include the prior's containment checks
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", LibraryEdgeWarning)
                    return fit_supervisor(hj_library, states, prior=prior,
                                          reference=reference if prior == "map" else None)

            def loop_once(prior=prior):
                admissible = [reachability.unsafe_set_contains(m, reference) if prior == "map" else True
                              for m in hj_library]
                best, best_ll = None, -np.inf
                for i, member in enumerate(hj_library):
                    v = member.interp(states)
                    mu = max(v.mean(), 0.0) if prior == "map" else v.mean()
                    ll = -0.5 * len(v) * (np.log(2 * np.pi * np.mean((v - mu) ** 2)) + 1)
                    if admissible[i] and ll > best_ll:
                        best, best_ll = i, ll
                return best

            seconds = best_time(fit_once, 5)
            baseline = best_time(loop_once, 5)
            rows.append({"benchmark": f"fit one supervisor ({prior})", "case": f"40 interventions, {members}, "
                                                                             f"{_shape(grid)}",
                         "seconds": seconds, "baseline": "per-member loop: ValueFunction.interp + numpy mean/var",
                         "baseline_seconds": baseline, "compile_seconds": 0.0,
                         "agree": f"same member chosen: {fit_once().index == loop_once()}", "target": "< 0.1 s",
                         "met": seconds < 0.1})
        rows.append(_interp_row(hj_library[1], rng))
    rows.append(_vmap_row(w_maxes, solver))
    rows.extend(_explore_rows())
    return rows


def _interp_row(vf, rng, n=1000):
    states = np.column_stack([rng.uniform(-7, 7, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
    grid, values = vf.grid_spec.build(), jnp.asarray(vf.values)
    hj_interp = jax.jit(jax.vmap(grid.interpolate, in_axes=(None, 0)))
    start = time.perf_counter()
    hj_interp(values, jnp.asarray(states)).block_until_ready()
    compile_s = time.perf_counter() - start
    ours = best_time(lambda: vf.interp(states), 20)
    theirs = best_time(lambda: np.asarray(hj_interp(values, jnp.asarray(states))), 20)
    gap = float(np.max(np.abs(vf.interp(states) - np.asarray(hj_interp(values, jnp.asarray(states))))))
    return {"benchmark": "interpolate V at robot states", "case": f"{n} states, {_shape(vf.grid_spec)}",
            "seconds": ours, "baseline": f"hj Grid.interpolate, jit + vmap (compile {compile_s:.2f} s, excluded)",
            "baseline_seconds": theirs, "compile_seconds": 0.0, "agree": f"max |dV| = {gap:.1e}", "target": "",
            "met": None}


def _vmap_row(w_maxes, solver):
    """All members advanced together (vmap, the GPU path) against the loop, on the quick grid, compiled."""
    compile_s = _compile_seconds(QUICK_GRID, solver, batched=True, members=len(w_maxes))
    with _private_cache():
        for batch in ("vmap", "loop"):  # compile for these shapes first
            value_library(w_maxes, RADIUS, QUICK_GRID, batch=batch, cache=False, progress=False)
        vmap = best_time(lambda: value_library(w_maxes, RADIUS, QUICK_GRID, batch="vmap", cache=False,
                                               progress=False), 1)
        loop = best_time(lambda: value_library(w_maxes, RADIUS, QUICK_GRID, cache=False, progress=False), 1)
        a = value_library(w_maxes, RADIUS, QUICK_GRID, batch="vmap", cache=False, progress=False)
        b = value_library(w_maxes, RADIUS, QUICK_GRID, cache=False, progress=False)
    gap = max(float(np.abs(x.values - y.values).max()) for x, y in zip(a, b))
    return {"benchmark": f"HJ library ({len(w_maxes)} members, compiled)", "case": f"{_shape(QUICK_GRID)}, vmap over "
                                                                                   "w_max",
            "seconds": vmap, "baseline": "loop over members, compiled", "baseline_seconds": loop,
            "compile_seconds": compile_s,
            "agree": f"max |dV| = {gap:.1e} (the batch steps until its slowest member converges)", "target": "",
            "met": None}


def _explore_rows():
    """Latency of the Explore view (issue 12): the first call builds the closed-form library."""
    explore.explore_library.cache_clear()
    explore._supervisor_value.cache_clear()
    start = time.perf_counter()
    explore.safe_set_view().savefig(io.BytesIO(), format="png")
    first = time.perf_counter() - start
    move = best_time(lambda: explore.safe_set_view(alpha=0.9, w_max=1.1).savefig(io.BytesIO(), format="png"), 3)
    case = (f"12 members, {_shape(explore.EXPLORE_GRID)}, closed form, 40 interventions, rendered to PNG "
            "(a latency target, no baseline)")
    return [{"benchmark": "Explore view, one slider move", "case": case, "seconds": move, "baseline": "",
             "baseline_seconds": None, "compile_seconds": 0.0, "agree": "", "target": "< 1 s on 2 cores",
             "met": move < 1},
            {"benchmark": "Explore view, first call (builds its library)", "case": case, "seconds": first,
             "baseline": "", "baseline_seconds": None, "compile_seconds": 0.0, "agree": "",
             "target": "< 3 s on 2 cores", "met": first < 3}]
