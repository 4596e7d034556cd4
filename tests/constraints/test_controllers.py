"""Eq. 2.23 checked by enumerating every feedback controller: a distribution under deterministic dynamics,
and not one under stochastic dynamics."""

import pytest

from mutual.constraints.controllers import controller_check, random_mdp


@pytest.mark.parametrize("horizon", [1, 2, 3])
def test_eq223_holds_for_deterministic_dynamics(horizon):
    out = controller_check(random_mdp(3, 2, horizon, deterministic=True, seed=horizon))
    assert out["max_gap"] < 1e-12 and out["eq223_total"] == pytest.approx(1, abs=1e-12)


def test_eq223_is_no_distribution_under_stochastic_dynamics():
    out = controller_check(random_mdp(3, 2, 2, deterministic=False, seed=0))
    assert out["causal_total"] == pytest.approx(1, abs=1e-12)  # the causal model is one
    assert out["controllers"] == 16 and out["eq223_total"] > 1.5 and out["max_gap"] > 0.05
    # one step: a controller is one action, and eq. 2.23 is eq. 2.19
    assert controller_check(random_mdp(3, 2, 1, deterministic=False, seed=0))["max_gap"] < 1e-12
