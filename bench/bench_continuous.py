"""Constraints from continuous demonstrations (issue 21): the 4-D case and what it runs on.

Rows:
1. The cart-pole of ``data/examples/cartpole.toml`` (20^4 = 160,000 cells x 5 forces, T = 40,
   barycentric) from 20 MPPI demonstrations, the cells model (``infer(..., model="cells")``):
   discretize, map, build the candidates (bounds, Lemma 3.2.1 thresholds) and run greedy inference to
   the stop rule, in a fresh process; a second run in the same process gives the compile time.
   Target: under 60 s on 2 cores, compile included. The row gives the wall and CPU seconds (all
   threads) of the cold run, the load average when it started (the machine may be shared) and the
   peak resident memory of that process. Also 10^4 and 14^4 (time and memory per resolution), and
   the points model (the default: the temperature fitted, tightest bounds, stop rule, intervals) at
   10^4 and 14^4 (no target: its backups run in numpy, once per temperature tried).
2. Round 1 of the 12^4 problem scored by the compiled gather backup on the states the
   demonstrations' starts reach (``engine="gather"``, :mod:`mutual.constraints.reachable`) against
   the numpy sparse backup of chapter 2 on the whole MDP (``engine="numpy", reachable=False``: a
   sparse matrix product per step and a log-sum-exp, what a practitioner would write): equal F and
   gains to 1e-10, the same ranking.
3. The Monte Carlo discretization of 20^4 cells (8 states per cell and force) in one process and on
   an embedded Dask LocalCluster of 2 workers (cluster start included): identical S.

Usage as a child process: ``python bench/bench_continuous.py cartpole CELLS``.
"""

import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SYSTEM = ROOT / "data" / "examples" / "cartpole.toml"
TARGET_SECONDS = 60.0


def _row(case, seconds, baseline="", baseline_seconds=None, target="", met=None, agree="", compile_seconds=None):
    return {"benchmark": "continuous constraints", "case": case, "seconds": seconds, "baseline": baseline,
            "baseline_seconds": baseline_seconds, "compile_seconds": compile_seconds, "agree": agree,
            "target": target, "met": met}


def _setting(cells, demos=20):
    from mutual.constraints.continuous import demonstrators as dm
    from mutual.constraints.continuous import load_system
    from mutual.constraints.continuous.experiments import with_cells
    spec = load_system(SYSTEM)
    problem, sim = with_cells(spec.problem, cells), spec.simulate
    recording = dm.mppi_rollouts(problem, sim["hidden"], dm.starts_around(sim["start"], sim["spread"], demos, sim["seed"]),
                                 sim["seed"] + 1, sim["samples"], sim["plan_steps"], sim["sigma"], margin=sim["margin"])
    return problem, recording, sim["hidden"]


def cartpole_run(cells, model="cells"):
    """The whole pipeline at ``cells`` per coordinate with ``model``: a dict of stage seconds and the outcome."""
    from mutual.constraints.continuous import boundary_errors, infer
    problem, recording, hidden = _setting(cells)
    load, cpu, start = os.getloadavg()[0], time.process_time(), time.perf_counter()
    options = dict(min_gain=0.1, scheduler="inline") if model == "cells" else {}
    run = infer(problem, recording, rounds=4, model=model, **options)
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    scored = len(run.candidates) if model == "cells" else sum(len(t) for t in run.rounds)
    return dict(cells=cells, model=model, seconds=seconds, cpu=cpu, load=load, stages=run.seconds, candidates=scored,
                rounds=len(run.chosen_regions()), stop=run.stop, chosen=run.labels(), error=boundary_errors(run, hidden)[0],
                peak_rss_gib=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20)


def _child(cells, warm=True, model="cells"):
    """``cartpole_run(cells, model)`` in a fresh process, twice with ``warm`` (the second without compiling)."""
    code = ("import json, sys; sys.path.insert(0, 'bench'); import mutual; from bench_continuous import cartpole_run; "
            f"runs = [cartpole_run({cells}, {model!r}) for _ in range({2 if warm else 1})]; "
            "runs[-1]['cold'] = runs[0]['seconds']; runs[-1]['cold_stages'] = runs[0]['stages']; "
            "runs[-1]['cold_cpu'] = runs[0]['cpu']; runs[-1]['cold_load'] = runs[0]['load']; print(json.dumps(runs[-1]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    run = json.loads(out.stdout.strip().splitlines()[-1])
    run["compile_seconds"] = run["cold"] - run["seconds"] if warm else None
    return run


def pipeline_rows(quick):
    rows = []
    runs = [(c, "cells") for c in ([8] if quick else [10, 14, 20])] + [(c, "points") for c in ([6] if quick else [10, 14])]
    for cells, model in runs:
        r = _child(cells, warm=(model == "cells" and cells == (8 if quick else 20)), model=model)
        stages = ", ".join(f"{k} {v:.1f} s" for k, v in r["cold_stages"].items())
        target = f"< {TARGET_SECONDS:.0f} s on 2 cores (compile included)" if cells == 20 and model == "cells" else ""
        what = ("discretize + candidates ({n} bounds, Lemma 3.2.1) + greedy to the stop rule" if model == "cells" else
                "point model + fitted temperature + {n} candidates scored + greedy to the stop rule, intervals")
        rows.append(_row(f"cart-pole {cells}^4 = {cells ** 4:,} cells x 5 forces, T = 40, barycentric, 20 MPPI "
                         f"demonstrations, {model} model: {what.format(n=r['candidates'])} ({r['rounds']} rounds, "
                         f"{r['stop']}); cold: {stages}; cold CPU {r['cold_cpu']:.1f} s "
                         f"(all threads), load average {r['cold_load']:.1f} at its start",
                         r["seconds"], target=target, met=(r["cold"] < TARGET_SECONDS) if target else None,
                         compile_seconds=r["compile_seconds"],
                         agree=f"peak RSS {r['peak_rss_gib']:.2f} GiB; chosen first: {(r['chosen'] or ['none'])[0]} "
                               f"(true x_dot <= 0.5, error {r['error']:.3g} m/s)"))
    return rows


def engine_rows(quick):
    """Round 1 by the compiled gather engine and by chapter 2's numpy engine, same candidates."""
    from mutual.constraints.backup import rank_candidates
    from mutual.constraints.continuous import discretize, region_candidates, to_demonstrations
    from mutual.constraints.continuous.candidates import bound_regions
    cells = 7 if quick else 12
    problem, recording, _ = _setting(cells)
    mapped = to_demonstrations(problem, recording, discretize(problem, scheduler="inline"))
    mdp = problem.mdp(mapped.transitions)
    cand = region_candidates(mdp, mapped.demos, problem.grid, bound_regions(problem.grid)).candidates
    rank_candidates(mdp, mapped.demos, cand.forbidden_matrix, engine="gather")                 # compile
    timed = {}
    for engine in ("gather", "numpy"):
        start = time.perf_counter()
        timed[engine] = rank_candidates(mdp, mapped.demos, cand.forbidden_matrix, engine=engine,
                                        reachable=engine == "gather")
        timed[engine + " s"] = time.perf_counter() - start
    (lf_g, g_g), (lf_n, g_n) = timed["gather"], timed["numpy"]
    live = np.isfinite(g_n)
    gaps = [np.abs(lf_g[live] - lf_n[live]), np.abs(g_g[live] - g_n[live])]
    gap = float(max(g.max() for g in gaps)) if live.any() else 0.0
    same = bool(np.array_equal(np.isfinite(g_g), live) and
                np.array_equal(np.argsort(np.where(live, lf_g, np.inf), kind="stable"),
                               np.argsort(np.where(live, lf_n, np.inf), kind="stable")))
    return [_row(f"round 1 of the cart-pole at {cells}^4 ({len(cand)} candidates, T = 40): compiled gather backup "
                 "on the states the demonstrations' starts reach",
                 timed["gather s"], "numpy sparse backup on the whole MDP (chapter 2's engine='numpy')", timed["numpy s"],
                 agree=f"max |log F gap| and |gain gap| {gap:.1e} (<= 1e-10: {gap <= 1e-10}), same ranking and "
                       f"feasibility: {same}")]


def dask_rows(quick):
    from dask.distributed import LocalCluster
    from mutual.constraints.continuous import discretize, load_system
    from mutual.constraints.continuous.experiments import with_cells
    cells = 8 if quick else 20
    problem = with_cells(load_system(SYSTEM).problem, cells).replace(scheme="sample", samples=8)
    start = time.perf_counter()
    inline = discretize(problem, scheduler="inline")
    inline_s = time.perf_counter() - start
    start = time.perf_counter()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        dask_S = discretize(problem, scheduler=cluster.scheduler_address)
    dask_s = time.perf_counter() - start
    same = (inline != dask_S).nnz == 0
    return [_row(f"Monte Carlo discretization of the cart-pole, {cells}^4 cells x 5 forces x 8 states "
                 f"({problem.grid.n_cells * 40:,} integrations): Dask LocalCluster of 2 workers (start included)",
                 dask_s, "the same chunks in one process", inline_s, agree=f"identical S: {same}")]


def run(quick=False):
    """The rows above; quick: 8^4 (points: 6^4) and 7^4, and no Dask row (a LocalCluster takes longer to start than the
    quick sizes take to compute)."""
    os.environ.setdefault("TQDM_DISABLE", "1")
    return pipeline_rows(quick) + engine_rows(quick) + ([] if quick else dask_rows(quick))


if __name__ == "__main__":
    if sys.argv[1:2] == ["cartpole"]:
        print(json.dumps(cartpole_run(int(sys.argv[2]), *sys.argv[3:4])))
    else:
        for row in run(quick="--quick" in sys.argv):
            print(row)
