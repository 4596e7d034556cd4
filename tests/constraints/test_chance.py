"""Chance constraints (eqs. 3.1-3.2) and maximum-likelihood thresholds (eq. 3.3, Lemma 3.2.1), checked
against plain loops over the demonstrations, the definition, and the exact likelihood (where Lemma 3.2.1
holds and where slip breaks it); their bad inputs (tables)."""

import numpy as np
import pytest

from mutual.constraints.backup import log_partition, rank_candidates
from mutual.constraints.chance import (chance_forbidden, constraint_mask, lemma_321_exact, max_likelihood_thresholds,
                                       threshold_levels)
from mutual.constraints.demonstrations import demonstration_log_likelihood, sample_demonstrations
from mutual.constraints.experiment import chapter3
from mutual.constraints.gridworld import GRID_ACTIONS, gridworld
from mutual.constraints.inference import constraint_candidates


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


def test_lemma_321_holds_on_deterministic_dynamics():
    g = gridworld(4, 3, (0, 0), (3, 0), slip=0.0, horizon=6)
    demos = sample_demonstrations(g.mdp, 30, constraint_mask(g.mdp, [g.state(1, 0)], 0.0), rng=2)
    table = lemma_321_exact(g.mdp, demos)
    assert len(table) and table["holds"].all()


def test_lemma_321_fails_on_the_exact_likelihood_with_slip():
    """With slip, Lemma 3.2.1's data-allowed threshold is not the exact likelihood's maximiser: cell (2, 6) of the
    chapter 3 experiment (its earlier three-truth layout) loses about 7e-5 nats per demonstration."""
    first = chapter3("first")
    demos = sample_demonstrations(first.grid.mdp, 100, first.truth, rng=0)
    row = lemma_321_exact(first.grid.mdp, demos, states=[first.grid.state(2, 6)]).iloc[0]
    assert not row["holds"] and row["gain at lowest"] == pytest.approx(-7.5e-5, rel=0.05)
    assert row["best psi"] >= max(threshold_levels(first.grid.mdp, first.grid.state(2, 6))[:-1])


G = gridworld(4, 4, (0, 0), (3, 0))
MDP0 = G.mdp


CASES = [
    # chance constraints (eqs. 3.1-3.2)
    (constraint_mask, (MDP0,), dict(states=[2.7]), ValueError, "states"),
    (constraint_mask, (MDP0,), dict(states=[99]), ValueError, "states"),
    (constraint_mask, (MDP0,), dict(states=[True]), ValueError, "states"),
    (constraint_mask, (MDP0,), dict(actions=[1.5]), ValueError, "actions"),
    (constraint_mask, (MDP0,), dict(actions=[9]), ValueError, "actions"),
    (constraint_mask, (MDP0,), dict(states=[1], psi=1.2), ValueError, "psi"),
    (constraint_mask, (MDP0,), dict(states=[1], psi=float("nan")), ValueError, "psi"),
    (constraint_mask, (MDP0,), dict(states=[1], psi="high"), ValueError, "psi"),
    (chance_forbidden, (MDP0, [1, 2], [0.1, 0.2, 0.3]), {}, ValueError, "psi"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i:02d}-{case[0].__name__}" for i, case in enumerate(CASES)])
def test_bad_input_raises_a_clear_error(fn, args, kwargs, error, phrase):
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value), f"message {str(info.value)!r} should mention {phrase!r}"
