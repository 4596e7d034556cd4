"""Benchmarks of chapter 4: the w_max value-function library and the supervisor fit.

Cold library: the compiled-once solver (``w_max`` traced, members in a loop) against one fresh
hj-reachability call per member (a new dynamics object each time, so each member recompiles),
measured in the same run on the same grid. Warm: the same library served from the disk cache.
Fit: one supervisor (40 interventions) against the cached library, MLE and MAP.
Interpolation: numpy trilinear (``ValueFunction.interp``) against hj-reachability's
``Grid.interpolate`` (jit + vmap) for a batch of robot states.
"""

import os
import tempfile
import time
from contextlib import contextmanager

import hj_reachability as hj
import jax
import jax.numpy as jnp
import numpy as np

from mutual.supervision import reachability
from mutual.supervision import supervisor
from mutual.constraints.complexity import best_time
from mutual.supervision.dubins import DubinsCar
from mutual.supervision.reachability import FULL_GRID, QUICK_GRID, SolverSpec, _initial_values, value_library
from mutual.supervision.supervisor import approach_scenes, NoisySupervisor
from mutual.supervision.fit import fit_supervisor

RADIUS = 1.0
W_MAXES = np.linspace(0.25, 3.0, 13)


def _fresh_call_per_member(w_maxes, grid_spec, solver):
    """The naive path: hj.step with a concrete dynamics object per member (recompiles each time)."""
    grid = grid_spec.build()
    settings = hj.SolverSettings.with_accuracy(solver.accuracy,
                                               hamiltonian_postprocessor=hj.solver.backwards_reachable_tube)
    for w in w_maxes:
        values, t = _initial_values(grid_spec, RADIUS), 0.0
        while True:
            new = hj.step(settings, DubinsCar(float(w)), grid, t, values, t - solver.chunk_time, progress_bar=False)
            change = float(jnp.max(jnp.abs(new - values)))
            values, t = new, t - solver.chunk_time
            if change < solver.tolerance or -t >= solver.max_time:
                break


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


def run(quick=False):
    grid = QUICK_GRID if quick else FULL_GRID
    w_maxes = W_MAXES[::4] if quick else W_MAXES  # quick: 4 members, so that CI stays short
    solver = SolverSpec()
    shape = "x".join(map(str, grid.shape))
    members = f"{len(w_maxes)} members"
    rows = []
    with _private_cache():
        _clear_compiled()
        start = time.perf_counter()
        value_library(w_maxes, RADIUS, grid, solver, progress=False)
        cold = time.perf_counter() - start
        _clear_compiled()
        start = time.perf_counter()
        _fresh_call_per_member(w_maxes, grid, solver)
        fresh = time.perf_counter() - start
        rows.append({"benchmark": f"reachability library ({members}, cold)", "case": f"{shape}, {solver.accuracy}",
                     "seconds": cold, "baseline": "one fresh hj.step call per member",
                     "baseline_seconds": fresh, "target": "<= 120 s on 2 cores (13 members)", "met": cold <= 120 * len(w_maxes) / 13})

        warm = best_time(lambda: value_library(w_maxes, RADIUS, grid, solver, progress=False), 3)
        rows.append({"benchmark": f"reachability library ({members}, warm)", "case": f"{shape}, disk cache",
                     "seconds": warm, "baseline": "", "baseline_seconds": None, "target": "< 1 s", "met": warm < 1})

        library = value_library(w_maxes, RADIUS, grid, solver, progress=False)
        rng = np.random.default_rng(0)
        states, _ = NoisySupervisor(library[1], 0.5, 0.05).first_interventions(
            approach_scenes(60, rng, RADIUS, 7.5), rng)
        reference = library[int(np.argmin(np.abs(w_maxes - 1.0)))]  # the member nearest the true robot
        for prior in ("mle", "map"):
            def fit_once():
                supervisor._conservative_members.cache_clear()  # MAP: include the prior's containment checks
                fit_supervisor(library, states[:40], prior=prior, reference=reference)
            fit = best_time(fit_once, 5)
            rows.append({"benchmark": "fit one supervisor", "case": f"{prior}, 40 interventions, {shape}",
                         "seconds": fit, "baseline": "", "baseline_seconds": None, "target": "< 0.1 s",
                         "met": fit < 0.1})
        rows.append(_interp_row(library[1], rng))
    rows.append(_vmap_row(w_maxes))
    return rows


def _interp_row(vf, rng, n=1000):
    states = np.column_stack([rng.uniform(-7, 7, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
    grid, values = vf.grid_spec.build(), jnp.asarray(vf.values)
    hj_interp = jax.jit(jax.vmap(grid.interpolate, in_axes=(None, 0)))
    hj_interp(values, jnp.asarray(states)).block_until_ready()
    ours = best_time(lambda: vf.interp(states), 20)
    theirs = best_time(lambda: np.asarray(hj_interp(values, jnp.asarray(states))), 20)
    return {"benchmark": "interpolate V at robot states", "case": f"{n} states, numpy trilinear",
            "seconds": ours, "baseline": "hj Grid.interpolate (jit + vmap)", "baseline_seconds": theirs,
            "target": "", "met": None}


def _vmap_row(w_maxes):
    """All members advanced together (vmap, the GPU path) against the loop, on the quick grid."""
    with _private_cache():
        for batch in ("vmap", "loop"):  # compile for these shapes first
            value_library(w_maxes, RADIUS, QUICK_GRID, batch=batch, cache=False, progress=False)
        vmap = best_time(lambda: value_library(w_maxes, RADIUS, QUICK_GRID, batch="vmap", cache=False,
                                           progress=False), 1)
        loop = best_time(lambda: value_library(w_maxes, RADIUS, QUICK_GRID, cache=False, progress=False), 1)
    shape = "x".join(map(str, QUICK_GRID.shape))
    return {"benchmark": f"reachability library ({len(w_maxes)} members, compiled)", "case": f"{shape}, vmap over w_max",
            "seconds": vmap, "baseline": "loop over members", "baseline_seconds": loop, "target": "",
            "met": None}
