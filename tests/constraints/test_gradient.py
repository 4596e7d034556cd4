"""Eq. 2.8's gradient of the demonstrations' log-likelihood against finite differences: per demonstration, and as
printed (off by exactly (|D| - 1) E f, with E f from an independent forward pass, Algorithm 1)."""

import numpy as np
import pytest

from mutual.constraints.backup import expected_features
from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.gradient import gradient_check, printed_gradient_check, reward_model
from mutual.constraints.gridworld import gridworld


def test_eq28_matches_finite_differences_for_deterministic_dynamics():
    g = gridworld(4, 3, (0, 0), (3, 0), slip=0.0, horizon=6)
    phi = np.random.default_rng(0).random((g.mdp.n_states, g.mdp.n_actions, 2))
    theta = np.array([-1.0, 0.5])
    demos = sample_demonstrations(reward_model(g.mdp, phi, theta), 50, rng=1)
    analytic, numeric, gap = gradient_check(g.mdp, phi, theta, demos)
    assert gap < 1e-7 and np.abs(analytic).max() > 1e-3
    with pytest.raises(ValueError, match="theta"):
        gradient_check(g.mdp, phi, [1.0], demos)


def test_the_printed_gradient_is_off_by_the_other_demonstrations_expectations():
    g = gridworld(4, 3, (0, 0), (3, 0), slip=0.0, horizon=6)
    phi = np.random.default_rng(0).random((g.mdp.n_states, g.mdp.n_actions, 2))
    theta = np.array([-1.0, 0.5])
    demos = sample_demonstrations(reward_model(g.mdp, phi, theta), 40, rng=1)
    printed, numeric, gap = printed_gradient_check(g.mdp, phi, theta, demos)
    expected = expected_features(reward_model(g.mdp, phi, theta), phi)
    np.testing.assert_allclose(printed - numeric, (demos.n - 1) * expected, atol=1e-5)
    assert gap > 1 and gap == np.max(np.abs(printed - numeric))
    one = sample_demonstrations(reward_model(g.mdp, phi, theta), 1, rng=2)      # |D| = 1: the printed form holds
    assert printed_gradient_check(g.mdp, phi, theta, one)[2] < 1e-6
