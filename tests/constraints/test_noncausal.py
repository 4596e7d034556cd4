"""The non-causal maximum-entropy distribution equals the causal one only under deterministic dynamics."""

from mutual.constraints.gridworld import gridworld
from mutual.constraints.noncausal import causal_versus_noncausal


def test_noncausal_distribution_matches_only_deterministic_dynamics():
    stochastic = causal_versus_noncausal(gridworld(2, 2, (0, 0), (1, 0), slip=0.2, horizon=2).mdp)
    deterministic = causal_versus_noncausal(gridworld(2, 2, (0, 0), (1, 0), slip=0.0, horizon=2).mdp)
    assert stochastic["dynamics_error_causal"] < 1e-12 < stochastic["dynamics_error_noncausal"]
    assert stochastic["kl"] > 1e-3 and deterministic["kl"] < 1e-12 and deterministic["policy_gap"] < 1e-12
