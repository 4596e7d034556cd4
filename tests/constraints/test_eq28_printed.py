"""Eq. (2.8) as printed against the gradient of the likelihood of all of D (mutual.constraints.gradient): the printed
form is off by exactly (|D| - 1) E f, where E f comes from an independent forward pass (Algorithm 1)."""

import numpy as np

from mutual.constraints.backup import expected_features
from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.gradient import printed_gradient_check, reward_model
from mutual.constraints.gridworld import gridworld


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
