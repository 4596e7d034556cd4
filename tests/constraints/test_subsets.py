"""Greedy against the best subset found by exhaustive search: greedy never beats it, meets the bound when the
dynamics are deterministic, and the bound is tested where greedy falls short."""

import numpy as np
import pytest

from mutual.constraints.backup import rank_candidates
from mutual.constraints.candidates import constraint_candidates
from mutual.constraints.chance import constraint_mask
from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.gridworld import gridworld
from mutual.constraints.subsets import BOUND, greedy_bound_survey, greedy_versus_best


def test_the_greedy_bound_is_tested_where_greedy_falls_short():
    survey = greedy_bound_survey(12, k_max=3, seed=0)
    assert survey["suboptimal"].any(), "no instance where greedy is sub-optimal: the bound would go untested"
    assert survey["ratio"].min() >= BOUND


def test_greedy_never_beats_the_best_subset_and_meets_the_bound_when_deterministic():
    g = gridworld(6, 5, (0, 0), (5, 0), slip=0.0)
    demos = sample_demonstrations(g.mdp, 10, constraint_mask(g.mdp, [g.state(3, 0)], 0.0), rng=4)
    cand = constraint_candidates(g.mdp, demos, chance=False)
    rows, violations = greedy_versus_best(g.mdp, demos, cand, 2)
    assert rows and violations == 0
    for r in rows:
        assert r["greedy"] <= r["best"] + 1e-12 and r["ratio"] >= BOUND
    # k = 1: greedy is exhaustive, and its removed mass is 1 - F of the smallest-F candidate (eq. 2.25)
    log_f, gain = rank_candidates(g.mdp, demos, cand.forbidden[:, :, cand.feasible])
    assert rows[0]["greedy"] == pytest.approx(rows[0]["best"])
    assert rows[0]["greedy"] == pytest.approx(1 - np.exp(np.nanmin(np.where(np.isfinite(gain), log_f, np.nan))))
