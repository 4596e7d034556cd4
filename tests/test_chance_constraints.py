"""Chance constraints (eqs. 3.1-3.2) and maximum-likelihood thresholds (eq. 3.3,
Lemma 3.2.1), checked against plain loops and the likelihood itself."""

import numpy as np
import pytest

from mutual.constraints.chance import chance_forbidden, constraint_mask, max_likelihood_thresholds
from mutual.constraints.inference import constraint_candidates
from mutual.constraints.backup import rank_candidates
from mutual.constraints.demonstrations import demonstration_log_likelihood, sample_demonstrations
from mutual.constraints.gridworld import GRID_ACTIONS, gridworld


@pytest.fixture(scope="module")
def world():
    g = gridworld(6, 5, (0, 0), (5, 0), slip=0.1)
    demos = sample_demonstrations(g.mdp, 40, constraint_mask(g.mdp, [g.state(2, 0)], 0.25), rng=7)
    return g, demos


def test_thresholds_match_a_loop_over_the_demonstrations(world):
    g, demos = world
    S = g.mdp.dense_transitions()
    expected = np.zeros(g.mdp.n_states)
    for states, actions in zip(demos.states, demos.actions):
        for x, a in zip(states[:-1], actions):
            expected = np.maximum(expected, S[x, a])
    np.testing.assert_array_equal(max_likelihood_thresholds(g.mdp, demos), expected)


def test_chance_forbidden_matches_the_definition(world):
    g, _ = world
    S = g.mdp.dense_transitions()
    states = np.array([3, 7, 7, 12])
    psi = np.array([0.0, 0.02, 0.5, 0.25])
    got = chance_forbidden(g.mdp, states, psi)
    for k, (s, p) in enumerate(zip(states, psi)):
        np.testing.assert_array_equal(got[:, :, k], S[:, :, s] > p)
    sparse = gridworld(6, 5, (0, 0), (5, 0), slip=0.1, sparse=True)
    np.testing.assert_array_equal(chance_forbidden(sparse.mdp, states, psi), got)


def test_psi_zero_is_a_hard_constraint_and_one_is_vacuous(world):
    g, _ = world
    x = g.state(3, 2)
    anywhere = gridworld(6, 5, (0, 0), (5, 0), slip=0.1, loiter="anywhere")
    hard = sample_demonstrations(anywhere.mdp, 300, constraint_mask(anywhere.mdp, [x], 0.0), rng=1)
    assert not np.any(hard.states == x)
    # with slip and loiter at the goal only, every move may slip next to the forbidden cell, whose
    # neighbours then have no allowed action: no trajectory satisfies a hard state constraint
    from mutual.constraints.backup import log_partition
    assert np.isneginf(log_partition(g.mdp, constraint_mask(g.mdp, [x], 0.0))[g.state(0, 0), 0])
    assert np.isfinite(log_partition(anywhere.mdp, constraint_mask(anywhere.mdp, [x], 0.0))[g.state(0, 0), 0])
    assert constraint_mask(g.mdp, [x], 1.0).all()
    mask = constraint_mask(g.mdp, [x], 0.25, [GRID_ACTIONS.index("N")])
    assert not mask[:, GRID_ACTIONS.index("N")].any()


def test_lemma_3_2_1_the_data_allowed_threshold_maximises_the_likelihood(world):
    g, demos = world
    psi_star = max_likelihood_thresholds(g.mdp, demos)
    base = np.ones((g.mdp.n_states, g.mdp.n_actions), dtype=bool)
    levels = np.unique(g.mdp.dense_transitions())
    checked = 0
    for x in np.flatnonzero((psi_star > 0) & (psi_star < 0.9)):   # entered by slips only
        below = np.nextafter(psi_star[x], 0)
        assert demonstration_log_likelihood(g.mdp, demos, constraint_mask(g.mdp, [x], below)) == -np.inf
        above = np.concatenate([[psi_star[x]], levels[levels > psi_star[x]]])
        log_f, _ = rank_candidates(g.mdp, demos, chance_forbidden(g.mdp, np.full(above.size, x), above), base)
        # likelihood scales by 1/F (eq. 2.25): raising psi never raises it, and lowers it somewhere.
        # (With loiter at the goal only, a threshold may also leave some state without an allowed
        # action and so make the demonstrations infeasible -- nan -- at and just above psi*.)
        ok = np.isfinite(log_f)
        assert ok.sum() >= 2 and np.all(np.diff(log_f[ok]) >= -1e-12) and log_f[ok][-1] > log_f[ok][0]
        assert np.all(ok[np.argmax(ok):])          # feasible from the first feasible level upwards
        checked += 1
    assert checked >= 3


def test_candidates_use_the_maximum_likelihood_thresholds(world):
    g, demos = world
    cand = constraint_candidates(g.mdp, demos)
    states = cand.kind == "state"
    np.testing.assert_array_equal(cand.psi[states], max_likelihood_thresholds(g.mdp, demos))
    assert cand.feasible[states].all()          # psi* never rules out a demonstration


@pytest.mark.parametrize("states, psi, message", [
    ([40], 0.1, "states"), ([1.5], 0.1, "states"), ([1], 1.2, "psi"), ([1], -0.1, "psi"), ([1, 2], [0.1, 0.2, 0.3], "psi"),
])
def test_bad_chance_constraints_raise_clear_errors(world, states, psi, message):
    g, _ = world
    with pytest.raises(ValueError, match=message):
        chance_forbidden(g.mdp, np.asarray(states), psi)


def test_bad_forbidden_actions_raise_clear_errors(world):
    g, _ = world
    with pytest.raises(ValueError, match="actions"):
        constraint_mask(g.mdp, actions=[9])
