"""Greedy selection against the best constraint set of the same size, by brute force (Section 2.4:
"this iterative approach can be shown to be bounded sub-optimal compared to selecting all the
constraints simultaneously [64]").

Scobee and Sastry's argument: with deterministic dynamics the demonstrations' likelihood under C
is proportional to Z_C^-N, and the mass a constraint set removes, f(C) = 1 - Z_C / Z_C0, is a
weighted coverage of the trajectories it rules out -- monotone and submodular -- so the greedy
choice of k constraints removes at least (1 - 1/e) of the mass the best k-set removes
(Nemhauser, Wolsey and Fisher). :func:`greedy_versus_best` computes both sides exactly on a
small problem (every k-subset of the feasible candidates scored by Algorithm 4) and counts
violations of diminishing returns, so the bound can be checked where it is proved
(deterministic dynamics) and measured where it is not (stochastic dynamics, where the causal
Z_C is no coverage function).
"""

import itertools

import numpy as np

from .backup import log_partition
from .feasibility import infeasible_candidates

BOUND = 1 - 1 / np.e
MAX_SUBSETS = 200_000


def _removed(mdp, demos, base, forbidden_sets):
    """f(C) = 1 - Z_C / Z_C0 averaged over the demonstrations' starts (eq. 2.25), and feasibility."""
    masks = base[:, :, None] & ~forbidden_sets
    starts = demos.states[:, 0]
    log_z0 = log_partition(mdp, base)[starts, 0]
    log_z = log_partition(mdp, masks)[starts]
    infeasible = infeasible_candidates(mdp, demos, base, forbidden_sets)
    return 1 - np.exp(log_z - log_z0[:, None]).mean(axis=0), ~infeasible


def greedy_versus_best(mdp, demos, candidates, k_max, base_mask=None):
    """For k = 1..``k_max``: the mass removed by the greedy k constraints (each round adds the
    feasible candidate that removes most, i.e. the smallest F, eq. 2.25) and by the best
    feasible k-subset of the feasible candidates (all of them scored). Returns a list of dicts
    (k, greedy, best, ratio = greedy / best, subsets) and the number of diminishing-returns
    violations f(A + c) - f(A) < f(B + c) - f(B) (A a subset of B) found among the greedy prefixes."""
    base = np.ones((mdp.n_states, mdp.n_actions), dtype=bool) if base_mask is None else np.asarray(base_mask)
    pool = np.flatnonzero(candidates.feasible)
    F = candidates.forbidden[:, :, pool]
    rows, chosen = [], []
    for k in range(1, min(k_max, pool.size) + 1):
        subsets = list(itertools.combinations(range(pool.size), k))
        if len(subsets) > MAX_SUBSETS:
            raise ValueError(f"k_max: {len(subsets)} subsets of size {k}, more than {MAX_SUBSETS}")
        sets = np.stack([F[:, :, list(s)].any(axis=2) for s in subsets], axis=2)
        removed, feasible = _removed(mdp, demos, base, sets)
        best = float(np.max(np.where(feasible, removed, -np.inf)))
        options = [c for c in range(pool.size) if c not in chosen]
        extended = np.stack([F[:, :, chosen + [c]].any(axis=2) for c in options], axis=2)
        gain, ok = _removed(mdp, demos, base, extended)
        if not ok.any():
            break
        chosen.append(options[int(np.argmax(np.where(ok, gain, -np.inf)))])
        greedy = float(np.max(np.where(ok, gain, -np.inf)))
        rows.append(dict(k=k, greedy=greedy, best=best, ratio=greedy / best if best > 0 else 1.0,
                         subsets=len(subsets)))
    return rows, _violations(mdp, demos, base, F, chosen)


def _violations(mdp, demos, base, F, chosen):
    """Count (A subset of B, c) with f(A + c) - f(A) < f(B + c) - f(B) - 1e-12 along the greedy prefixes."""
    prefixes = [chosen[:i] for i in range(len(chosen) + 1)]
    count = 0
    for c in range(F.shape[2]):
        sets = [p for p in prefixes if c not in p]
        stacks = [np.zeros(F.shape[:2], dtype=bool) if not p else F[:, :, p].any(axis=2) for p in sets]
        with_c = [s | F[:, :, c] for s in stacks]
        values, _ = _removed(mdp, demos, base, np.stack(stacks + with_c, axis=2))
        marginal = values[len(sets):] - values[: len(sets)]
        count += sum(marginal[i] < marginal[j] - 1e-12 for i, j in itertools.combinations(range(len(sets)), 2))
    return int(count)
