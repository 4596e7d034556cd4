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


def _removed(mdp, demos, base, forbidden_sets, engine="auto"):
    """f(C) = 1 - Z_C / Z_C0 averaged over the demonstrations' starts (eq. 2.25), and feasibility."""
    masks = base[:, :, None] & ~forbidden_sets
    starts = demos.states[:, 0]
    log_z0 = log_partition(mdp, base, engine)[starts, 0]
    log_z = log_partition(mdp, masks, engine)[starts]
    infeasible = infeasible_candidates(mdp, demos, base, forbidden_sets)
    return 1 - np.exp(log_z - log_z0[:, None]).mean(axis=0), ~infeasible


def greedy_versus_best(mdp, demos, candidates, k_max, base_mask=None, violations=True, engine="auto"):
    """For k = 1..``k_max``: the mass removed by the greedy k constraints (each round adds the
    feasible candidate that removes most, i.e. the smallest F, eq. 2.25) and by the best
    feasible k-subset of the feasible candidates (all of them scored). Returns a list of dicts
    (k, greedy, best, ratio = greedy / best, subsets) and the number of diminishing-returns
    violations f(A + c) - f(A) < f(B + c) - f(B) (A a subset of B) found among the greedy prefixes
    (None with ``violations=False``). ``engine`` as in :func:`~mutual.constraints.backup.log_partition`."""
    base = np.ones((mdp.n_states, mdp.n_actions), dtype=bool) if base_mask is None else np.asarray(base_mask)
    pool = np.flatnonzero(candidates.feasible)
    F = candidates.forbidden[:, :, pool]
    rows, chosen = [], []
    for k in range(1, min(k_max, pool.size) + 1):
        subsets = list(itertools.combinations(range(pool.size), k))
        if len(subsets) > MAX_SUBSETS:
            raise ValueError(f"k_max: {len(subsets)} subsets of size {k}, more than {MAX_SUBSETS}")
        sets = np.stack([F[:, :, list(s)].any(axis=2) for s in subsets], axis=2)
        removed, feasible = _removed(mdp, demos, base, sets, engine)
        best = float(np.max(np.where(feasible, removed, -np.inf)))
        options = [c for c in range(pool.size) if c not in chosen]
        extended = np.stack([F[:, :, chosen + [c]].any(axis=2) for c in options], axis=2)
        gain, ok = _removed(mdp, demos, base, extended, engine)
        if not ok.any():
            break
        chosen.append(options[int(np.argmax(np.where(ok, gain, -np.inf)))])
        greedy = float(np.max(np.where(ok, gain, -np.inf)))
        rows.append(dict(k=k, greedy=greedy, best=best, ratio=greedy / best if best > 0 else 1.0,
                         subsets=len(subsets)))
    return rows, (_violations(mdp, demos, base, F, chosen) if violations else None)


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


def lattice_mdp(width=4, length=4, reward_scale=2.0, seed=0):
    """A deterministic layered world where routes cross: ``length`` layers of ``width`` cells, each step moves
    one layer on and at most one cell sideways (three actions, clipped at the edges), then an absorbing end;
    random running rewards in [-``reward_scale``, 0]; the agent starts in the middle of the first layer.
    Many routes share cells, so the mass a cell removes overlaps: the coverage problem where greedy
    selection can fall short of the best k-set."""
    from .mdp import MDP

    rng = np.random.default_rng(seed)
    X, end = width * length + 1, width * length
    S = np.zeros((X, 3, X))
    for layer in range(length):
        for w in range(width):
            for a, dw in enumerate((-1, 0, 1)):
                S[layer * width + w, a, end if layer == length - 1 else (layer + 1) * width + min(max(w + dw, 0), width - 1)] = 1
    S[end, :, end] = 1
    reward = -reward_scale * rng.random((X, 3))
    reward[end] = 0.0
    p0 = np.zeros(X)
    p0[width // 2] = 1.0
    return MDP(S, reward, length, initial=p0)


def greedy_bound_survey(n_instances=40, k_max=3, width=4, length=4, seed=0):
    """The bound where it has teeth: greedy against the best k-set (:func:`greedy_versus_best`, by brute
    force) on ``n_instances`` random :func:`lattice_mdp` worlds, each with one demonstration of the
    unconstrained agent and every state candidate (psi = 0) it leaves feasible. Returns a DataFrame, one row
    per instance and k (``greedy``, ``best``, ``ratio``, ``suboptimal``: greedy removes less than the best)."""
    import pandas as pd

    from .candidates import constraint_candidates
    from .demonstrations import sample_demonstrations

    rows = []
    for i in range(n_instances):
        mdp = lattice_mdp(width, length, seed=[seed, i])
        demos = sample_demonstrations(mdp, 1, rng=np.random.default_rng([seed, i]))
        cand = constraint_candidates(mdp, demos, actions=False, chance=False)
        found, _ = greedy_versus_best(mdp, demos, cand, k_max, violations=False, engine="numpy")
        rows += [dict(instance=i, **r, suboptimal=bool(r["ratio"] < 1 - 1e-9)) for r in found]
    return pd.DataFrame(rows)
