"""What a policy does, exactly: forward passes against enumeration of every trajectory of tiny MDPs, and
sampled rollouts against the forward pass; bad inputs (a table)."""

import numpy as np
import pytest

from mutual.constraints import sample_demonstrations, soft_policy
from mutual.constraints.demonstrations import categorical
from mutual.constraints.gridworld import gridworld
from mutual.cycle.outcomes import policy_outcomes, rollout_outcomes, sample_rollouts

from helpers.tiny_mdps import T, constraint, random_policy, reward, tiny_mdp, trajectories


@pytest.mark.parametrize("seed", range(3))
def test_policy_outcomes_match_enumeration(seed):
    mdp = tiny_mdp(seed)
    rng = np.random.default_rng(seed)
    pi, allowed, avoid = random_policy(rng), constraint(mdp), [1]
    expected = {"p_break": 0.0, "p_enter": 0.0, "p_either": 0.0, "expected_reward": 0.0}
    for states, actions, dyn in trajectories(mdp):
        p = dyn * np.prod([pi[t, states[t], actions[t]] for t in range(T)])
        broke = not all(allowed[states[t], actions[t]] for t in range(T))
        entered = any(s in avoid for s in states)
        expected["p_break"] += p * broke
        expected["p_enter"] += p * entered
        expected["p_either"] += p * (broke or entered)
        expected["expected_reward"] += p * reward(mdp, states, actions)
    got = policy_outcomes(mdp, pi, allowed=allowed, forbidden_states=avoid)
    for key, value in expected.items():
        assert got[key] == pytest.approx(value, abs=1e-12), key


def test_sampled_rollouts_agree_with_the_forward_pass():
    mdp = tiny_mdp(7)
    pi = random_policy(np.random.default_rng(7))
    exact = policy_outcomes(mdp, pi, allowed=constraint(mdp), forbidden_states=[2])
    sampled = rollout_outcomes(mdp, sample_rollouts(mdp, pi, 40000, rng=1), allowed=constraint(mdp), forbidden_states=[2])
    for key in ("p_break", "p_enter", "p_either"):
        se = np.sqrt(exact[key] * (1 - exact[key]) / 40000)
        assert abs(sampled[key] - exact[key]) < 5 * se + 1e-9, key
    assert sampled["expected_reward"] == pytest.approx(exact["expected_reward"], abs=0.05)


def test_rollouts_of_the_soft_policy_are_the_demonstrations_of_the_same_seed():
    """One sampler: rolling out chapter 2's soft policy draws the same trajectories, in the same order, as
    sampling demonstrations with the same seed; a dead state's all-zero row falls back to the last action."""
    mdp = gridworld(4, 3, start=(0, 0), goal=(3, 0), slip=0.2, horizon=6).mdp
    rollouts = sample_rollouts(mdp, soft_policy(mdp), 50, rng=3)
    demos = sample_demonstrations(mdp, 50, rng=3)
    np.testing.assert_array_equal(rollouts.states, demos.states)
    np.testing.assert_array_equal(rollouts.actions, demos.actions)
    assert categorical(np.zeros((3, 4)), np.random.default_rng(0)).tolist() == [3, 3, 3]


GRID = gridworld(3, 3, start=(0, 0), goal=(2, 0), slip=0.1, horizon=4)
GRID_MDP = GRID.mdp
GRID_T, GRID_X, GRID_A = GRID_MDP.horizon, GRID_MDP.n_states, GRID_MDP.n_actions
UNIFORM = np.full((GRID_T, GRID_X, GRID_A), 1.0 / GRID_A)


CASES = [
    (policy_outcomes, (GRID_MDP, UNIFORM[:-1]), {}, ValueError, "policy: shape"),
    (policy_outcomes, (GRID_MDP, -UNIFORM), {}, ValueError, "non-negative"),
    (policy_outcomes, (GRID_MDP, 2 * UNIFORM), {}, ValueError, "sum to 1"),
    (policy_outcomes, (GRID_MDP, UNIFORM), {"allowed": np.ones((GRID_X, GRID_A))}, ValueError, "allowed: must be a boolean"),
    (policy_outcomes, (GRID_MDP, UNIFORM), {"forbidden_states": [GRID_X]}, ValueError, "forbidden_states"),
    (sample_rollouts, (GRID_MDP, UNIFORM, 0), {}, ValueError, "n: must be a positive integer"),
    (sample_rollouts, (GRID_MDP, UNIFORM[:, :, :-1], 3), {}, ValueError, "policy: shape"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{c[0].__name__ if hasattr(c[0], '__name__') else 'call'}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase):
        fn(*args, **kwargs)
