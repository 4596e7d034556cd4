"""Eq. 2.8's gradient of the demonstrations' log-likelihood against finite differences."""

import numpy as np
import pytest

from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.gradient import gradient_check, reward_model
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
