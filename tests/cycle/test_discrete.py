"""The discrete loop's studies: the observer study carries the log odds across episodes, and comparing robots
and sweeping alpha are the forward passes."""

import numpy as np
import pytest

from mutual.constraints.mdp import soft_policy
from mutual.cycle.observer import log_odds_paths, step_log_ratio, time_to_confidence
from mutual.cycle.outcomes import policy_outcomes, sample_rollouts

from helpers.tiny_mdps import T, constraint, tiny_mdp


def test_observer_study_carries_the_log_odds_across_episodes():
    from scipy.special import logit
    from mutual.cycle.discrete import observer_study

    mdp = tiny_mdp(2)
    c1 = constraint(mdp)
    policy = soft_policy(mdp, c1)
    table, curves = observer_study(mdp, {"plain": policy}, c1, 50, 2, np.random.default_rng(3), level=0.8, prior=0.4)
    rolls = sample_rollouts(mdp, policy, 100, np.random.default_rng(3))
    gained = log_odds_paths(step_log_ratio(mdp, c1), rolls, 0.4) - logit(0.4)
    first, second = gained[0::2], gained[1::2]
    path = np.concatenate([first, first[:, -1:] + second[:, 1:]], axis=1) + logit(0.4)
    np.testing.assert_allclose(curves["plain"]["mean_posterior"], (1 / (1 + np.exp(-path))).mean(axis=0), atol=1e-12)
    expected = time_to_confidence(1 / (1 + np.exp(-path)), 0.8)
    np.testing.assert_array_equal(curves["plain"]["time"], expected)
    assert table["p_confident_ep2"].iloc[0] == np.mean(expected <= 2 * T)


def test_compare_robots_and_alpha_sweep_are_the_forward_passes():
    from mutual.cycle.discrete import alpha_sweep, compare_robots
    from mutual.cycle.learning import ConstraintSet
    from mutual.constraints.gridworld import gridworld

    grid = gridworld(5, 5, start=(0, 2), goal=(4, 2), slip=0.1)
    truth = ConstraintSet([grid.state(2, 2)], 0.25)
    robots = compare_robots(grid.mdp, truth, {"none": None, "truth": truth.mask(grid.mdp)}).set_index("robot")
    direct = policy_outcomes(grid.mdp, soft_policy(grid.mdp), allowed=truth.mask(grid.mdp), forbidden_states=truth.states)
    assert robots.loc["none", "p_break"] == pytest.approx(direct["p_break"]) and direct["p_break"] > 0.1
    assert robots.loc["truth", "p_break"] == 0.0
    sweep = alpha_sweep(grid.mdp, truth.mask(grid.mdp), truth.mask(grid.mdp), [np.inf, 1.0, 0.05])
    assert sweep["mean_log_odds_over_time"].is_monotonic_increasing                      # more legible as alpha falls
    assert np.allclose(sweep["p_break"], 0.0)
