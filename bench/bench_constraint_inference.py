"""Constraint ranking (Chapter 2, Algorithms 2-4): the vectorized backup against a
literal transcription of Algorithm 4's pseudocode and against Algorithm 2, its
growth with the number of states, and the 30 x 30 full ranking target."""

import numpy as np

from mutual.constraints.chance import chance_forbidden
from mutual.constraints.complexity import all_single_candidates, best_time, power_law_exponent
from mutual.constraints.inference import constraint_candidates
from mutual.constraints.backup import (constraint_accrual, log_partition, log_partition_literal, rank_candidates)
from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.gridworld import gridworld


def _row(case, seconds, baseline="", baseline_seconds=None, target="", met=None):
    return {"benchmark": "constraint ranking", "case": case, "seconds": seconds, "baseline": baseline,
            "baseline_seconds": baseline_seconds, "target": target, "met": met}


def run(quick=False):
    rows = []
    # 1. vectorized Algorithm 4 vs the literal pseudocode, 10 x 10 grid, all 109 candidates
    horizon = 3 if quick else 20
    g = gridworld(10, 10, (0, 0), (9, 0), slip=0.1, horizon=horizon, sparse=True)
    masks = all_single_candidates(g.mdp)
    fast = best_time(lambda: log_partition(g.mdp, masks), 5)
    slow = best_time(lambda: log_partition_literal(g.mdp, masks), 1)
    rows.append(_row(f"Alg. 4 vectorized (sparse S), 10x10, {masks.shape[2]} candidates, T={horizon}", fast,
                     "literal loop of the pseudocode", slow, ">= 100x faster", slow / fast >= 100))

    # 2. against Algorithm 2 (forward accrual) on deterministic dynamics
    d = gridworld(10, 10, (0, 0), (9, 0), slip=0.0)
    masks = all_single_candidates(d.mdp)
    full = np.ones(masks.shape[:2], dtype=bool)
    alg4 = best_time(lambda: log_partition(d.mdp, masks), 3)
    alg2 = best_time(lambda: constraint_accrual(d.mdp, full, masks), 3)
    rows.append(_row(f"Alg. 4 vectorized, 10x10 deterministic, T={d.mdp.horizon}", alg4,
                     "Alg. 2 (Scobee-Sastry) vectorized", alg2, "same order (0.2x-5x)", 0.2 <= alg2 / alg4 <= 5))

    # 3. growth with |X|: all single-state candidates, sparse S, T fixed at 20
    sides = [5, 10, 15, 20] if quick else [5, 10, 20, 30, 40, 50]
    seconds = []
    for n in sides:
        g = gridworld(n, n, (0, 0), (n - 1, 0), slip=0.1, horizon=20, sparse=True)
        masks = ~chance_forbidden(g.mdp, np.arange(n * n), 0.0)
        seconds.append(best_time(lambda: log_partition(g.mdp, masks), 1 if n >= 30 else 3))
        rows.append(_row(f"Alg. 4, {n}x{n}, |C|=|X|={n * n}, sparse S, T=20", seconds[-1]))
    slope = power_law_exponent(np.square(sides[1:]), seconds[1:])
    rows.append(_row(f"fitted exponent of time vs |X| ({sides[1]}x{sides[1]}..{sides[-1]}x{sides[-1]}): {slope:.2f}",
                     float(sum(seconds)), target="<= 2.3 (claim: 2; cost ~ |X| |A| |C| with sparse S, |C| = |X|)", met=slope <= 2.3))

    # 4. the target: full ranking of a 30 x 30 grid, T = 60, from 100 demonstrations
    n = 20 if quick else 30
    g = gridworld(n, n, (0, 0), (n - 1, 0), slip=0.1, sparse=True)
    demos = sample_demonstrations(g.mdp, 100, rng=0)

    def ranking():
        cand = constraint_candidates(g.mdp, demos)
        return rank_candidates(g.mdp, demos, cand.forbidden)

    t = best_time(ranking, 1 if quick else 2)
    rows.append(_row(f"full ranking {n}x{n}, {n * n + 9} candidates, T={g.mdp.horizon}, sparse S", t,
                     target="< 10 s on 2 cores" if n == 30 else "(quick: smaller grid)", met=t < 10 if n == 30 else None))
    return rows
