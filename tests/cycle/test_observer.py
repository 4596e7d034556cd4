"""The human observer's likelihood-ratio test between maximum-causal-entropy models: the log ratio against
brute-force prefix likelihoods, the expected log odds and refutation against enumeration, time to
confidence and posteriors; bad inputs (a table)."""

import numpy as np
import pytest

from mutual.constraints.demonstrations import Demonstrations
from mutual.constraints.gridworld import gridworld
from mutual.constraints.mdp import soft_policy
from mutual.cycle.observer import (expected_log_odds, log_odds_paths, posterior_paths, step_log_ratio,
                                   time_to_confidence)
from mutual.cycle.outcomes import sample_rollouts

from helpers.tiny_mdps import A, T, X, constraint, maxent_prefix_log_likelihood, random_policy, tiny_mdp, trajectories


@pytest.mark.parametrize("seed", range(3))
def test_observer_log_ratio_equals_brute_force_prefix_likelihoods(seed):
    mdp = tiny_mdp(seed, deterministic=True)
    c1 = constraint(mdp)
    ll1, ll0 = maxent_prefix_log_likelihood(mdp, c1), maxent_prefix_log_likelihood(mdp, np.ones((X, A), bool))
    ratio = step_log_ratio(mdp, c1)
    for states, actions, _ in trajectories(mdp):
        if not all(c1[states[t], actions[t]] for t in range(T)):
            continue
        path = log_odds_paths(ratio, Demonstrations(states[None], actions[None]), prior=0.5)[0]
        brute = [ll1[tuple(actions[:t])] - ll0[tuple(actions[:t])] for t in range(T + 1)]
        np.testing.assert_allclose(path, brute, atol=1e-10)


@pytest.mark.parametrize("seed", range(3))
def test_expected_log_odds_and_refutation_match_enumeration(seed):
    mdp = tiny_mdp(seed)
    ratio = step_log_ratio(mdp, constraint(mdp))
    pi = random_policy(np.random.default_rng(seed + 10))          # breaks C1 with positive probability
    mean, refuted = expected_log_odds(mdp, pi, ratio, prior=0.3)
    alive, acc, dead = np.zeros(T + 1), np.zeros(T + 1), np.zeros(T + 1)
    for states, actions, dyn in trajectories(mdp):
        p = dyn * np.prod([pi[t, states[t], actions[t]] for t in range(T)])
        steps = np.array([ratio[t, states[t], actions[t]] for t in range(T)])
        for t in range(T + 1):
            if np.all(np.isfinite(steps[:t])):
                alive[t] += p
                acc[t] += p * steps[:t].sum()
            else:
                dead[t] += p
    np.testing.assert_allclose(refuted, dead, atol=1e-12)
    np.testing.assert_allclose(mean, np.log(0.3 / 0.7) + acc / alive, atol=1e-10)


def test_time_to_confidence_and_posteriors():
    post = np.array([[0.5, 0.9, 0.96, 0.99], [0.5, 0.6, 0.7, 0.8]])
    np.testing.assert_array_equal(time_to_confidence(post, 0.95), [2.0, np.nan])
    mdp = tiny_mdp(1, deterministic=True)
    ratio = step_log_ratio(mdp, constraint(mdp))
    demos = sample_rollouts(mdp, soft_policy(mdp, constraint(mdp)), 5, rng=0)
    p = posterior_paths(ratio, demos, prior=0.2)
    assert np.allclose(p[:, 0], 0.2) and np.all((p >= 0) & (p <= 1))


GRID = gridworld(3, 3, start=(0, 0), goal=(2, 0), slip=0.1, horizon=4)
GRID_MDP = GRID.mdp
GRID_T, GRID_X, GRID_A = GRID_MDP.horizon, GRID_MDP.n_states, GRID_MDP.n_actions
UNIFORM = np.full((GRID_T, GRID_X, GRID_A), 1.0 / GRID_A)
RATIO = np.zeros((GRID_T, GRID_X, GRID_A))
MASK = np.ones((GRID_X, GRID_A), dtype=bool)
DEMOS = Demonstrations(np.full((2, GRID_T + 1), GRID.state(*GRID.goal)), np.full((2, GRID_T), 8))      # loiter at the goal


CASES = [
    (step_log_ratio, (GRID_MDP, np.ones((GRID_X, GRID_A))), {}, ValueError, "mask_h1"),
    (step_log_ratio, (GRID_MDP, MASK, np.ones((GRID_X, GRID_A + 1), bool)), {}, ValueError, "mask_h0"),
    (log_odds_paths, (RATIO, DEMOS), {"prior": 1.0}, ValueError, "prior"),
    (log_odds_paths, (RATIO[:, :, :3], DEMOS), {}, ValueError, "step_ratio"),
    (time_to_confidence, (np.zeros((1, 3)), 1.0), {}, ValueError, "level"),
    (expected_log_odds, (GRID_MDP, UNIFORM, RATIO[:-1]), {}, ValueError, "step_ratio"),
    (expected_log_odds, (GRID_MDP, UNIFORM, RATIO), {"prior": 0.0}, ValueError, "prior"),
    (expected_log_odds, (GRID_MDP, UNIFORM, RATIO + np.inf), {}, ValueError, "H0's support"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{c[0].__name__ if hasattr(c[0], '__name__') else 'call'}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase):
        fn(*args, **kwargs)
