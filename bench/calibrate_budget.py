"""Refit the time constants of ``mutual.budget`` on this machine: each runs a small instance of its request
(seconds, on one core) and prints the measured time per unit beside the module's constant.

Usage: ``.venv/bin/python bench/calibrate_budget.py`` (about a minute; not part of ``make bench``, whose
budget goes to speed rows). A ratio far from 1 on a quiet machine is a reason to change the constant.
"""

import math
import os
import time
import warnings

import numpy as np
import pandas as pd

from mutual import budget

EXAMPLES = os.path.join(os.path.dirname(__file__), os.pardir, "data", "examples")


def _timed(fn):
    fn()                                                   # warm: imports and compilation are not the request
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def rk4():
    from mutual.constraints.continuous import load_system
    from mutual.constraints.continuous.discretization import discretize
    p = load_system(os.path.join(EXAMPLES, "pendulum.toml")).problem
    seconds = _timed(lambda: discretize(p, scheduler="inline"))
    return "RK4_SECONDS", seconds / (p.grid.n_cells * p.n_actions * p.samples * p.substeps)


def anova_pair():
    from mutual.study import pairwise_comparisons, rm_anova
    rng = np.random.default_rng(0)
    data = pd.DataFrame([(f"s{s}", f"L{k:02d}", rng.normal()) for s in range(3) for k in range(20)],
                        columns=["s", "level", "v"])
    anova = rm_anova(data, "v", "level", "s")
    return "ANOVA_PAIR_SECONDS", _timed(lambda: pairwise_comparisons(anova)) / 190


def continuous_backup():
    from mutual.constraints.continuous import infer, load_system, read_recording
    from mutual.constraints.continuous.discretization import discretize
    spec = load_system(os.path.join(EXAMPLES, "pendulum.toml"))
    p = spec.problem
    rec = read_recording(os.path.join(EXAMPLES, "pendulum_trajectories.csv"), p.system.state_names,
                         p.system.control_names)
    S = discretize(p, scheduler="inline")
    seconds = _timed(lambda: infer(p, rec, transitions=S))
    regions = budget.candidate_regions(p.grid.shape, ("bound",))
    return "CONTINUOUS_BACKUP_SECONDS", seconds / (p.horizon * p.grid.n_cells * p.n_actions * regions)


def lq_step():
    from mutual.motion.spec import legible_spec, solve_legible
    d = [[10 * math.cos(2 * math.pi * i / 10), 20 + 10 * math.sin(2 * math.pi * i / 10)] for i in range(10)]
    spec = legible_spec({"dynamics": "single-integrator", "start": [0.0, 0.0], "goal": [4.0, 4.0],
                         "distractors": d, "horizon": 1.0, "steps": 3000, "alpha": 1.0})
    return "LQ_STEP_SECONDS", _timed(lambda: solve_legible(spec)) / (3000 * 11)


def hj_node():
    from mutual.supervision.reachability import QUICK_GRID, value_library
    seconds = _timed(lambda: value_library([1.0, 2.0], 1.0, QUICK_GRID, cache=False, progress=False))
    return "HJ_NODE_SECONDS", seconds / (2 * math.prod(QUICK_GRID.shape))


def grid_backup():
    from mutual.constraints import constraint_candidates, greedy_inference, load_demonstrations, world
    mdp = world.load_world(os.path.join(EXAMPLES, "world.toml")).mdp
    demos = load_demonstrations(os.path.join(EXAMPLES, "demonstrations.csv"), mdp)
    cand = constraint_candidates(mdp, demos)
    seconds = _timed(lambda: greedy_inference(mdp, demos, cand, 10, criterion="F"))
    return "GRID_BACKUP_SECONDS", seconds / (10 * len(cand) * mdp.horizon * mdp.n_states * mdp.n_actions)


def main():
    warnings.simplefilter("ignore")
    print(f"{'constant':<28}{'in mutual.budget':>18}{'measured':>12}{'ratio':>8}")
    for measure in (rk4, anova_pair, continuous_backup, lq_step, hj_node, grid_backup):
        name, measured = measure()
        value = getattr(budget, name)
        print(f"{name:<28}{value:>18.3g}{measured:>12.3g}{measured / value:>8.2f}", flush=True)


if __name__ == "__main__":
    main()
