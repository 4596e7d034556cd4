"""The backups of Algorithms 1-4 against a literal transcription of the pseudocode, Monte Carlo simulation,
the exact demonstration likelihood and each other (dense and sparse transitions, numpy and the compiled
engine); their bad inputs (tables)."""

import numpy as np
import pytest

from mutual.constraints.backup import (constraint_accrual, expected_features, log_partition, log_partition_literal,
                                       rank_candidates, value_ratio)
from mutual.constraints.chance import constraint_mask
from mutual.constraints.demonstrations import demonstration_log_likelihood, sample_demonstrations
from mutual.constraints.gridworld import GRID_ACTIONS, gridworld
from mutual.constraints.inference import constraint_candidates, greedy_inference
from mutual.constraints.mdp import MDP, soft_policy


@pytest.fixture(scope="module")
def stochastic():
    g = gridworld(6, 5, (0, 0), (5, 0), slip=0.1, sparse=True)
    demos = sample_demonstrations(g.mdp, 40, constraint_mask(g.mdp, [g.state(2, 0)], 0.25), rng=3)
    return g, demos, constraint_candidates(g.mdp, demos)


def test_vectorized_algorithm_4_matches_the_literal_pseudocode():
    g = gridworld(3, 3, (0, 0), (2, 0), slip=0.1, horizon=5)
    rng = np.random.default_rng(0)
    masks = rng.random((9, 9, 6)) < 0.9
    masks[:, GRID_ACTIONS.index("loiter")] = True
    np.testing.assert_allclose(log_partition(g.mdp, masks), log_partition_literal(g.mdp, masks), rtol=1e-12)


def test_algorithm_3_ratio_equals_algorithm_4_for_every_candidate(stochastic):
    g, demos, cand = stochastic
    base = constraint_mask(g.mdp, actions=[GRID_ACTIONS.index("W")])
    masks = base[:, :, None] & ~cand.forbidden
    V0 = log_partition(g.mdp, base)[:, 0]
    V = log_partition(g.mdp, masks)
    log_f = value_ratio(g.mdp, base, masks)
    finite = np.isfinite(V)
    np.testing.assert_array_equal(np.isneginf(log_f), ~finite)
    np.testing.assert_allclose(np.exp(log_f[finite]), np.exp((V - V0[:, None])[finite]), atol=1e-10)


def test_dense_and_sparse_transitions_agree(stochastic):
    g, _, cand = stochastic
    dense = MDP(g.mdp.dense_transitions(), g.mdp.reward, g.mdp.horizon, g.mdp.terminal_reward, g.mdp.initial,
                g.mdp.allowed)
    masks = ~cand.forbidden[:, :, ::5]
    np.testing.assert_allclose(log_partition(dense, masks), log_partition(g.mdp, masks), rtol=1e-12)


def test_deterministic_dynamics_algorithms_2_3_4_agree():
    g = gridworld(5, 4, (0, 0), (4, 0), slip=0.0)
    demos = sample_demonstrations(g.mdp, 30, rng=1)
    cand = constraint_candidates(g.mdp, demos, chance=False)
    base = np.ones((20, 9), dtype=bool)
    masks = base[:, :, None] & ~cand.forbidden
    F3 = np.exp(value_ratio(g.mdp, base, masks)[0])
    np.testing.assert_allclose(constraint_accrual(g.mdp, base, masks), F3, atol=1e-12)
    # and the thesis's ranking F is then the exact likelihood ratio
    log_f, gain = rank_candidates(g.mdp, demos, cand.forbidden[:, :, cand.feasible])
    np.testing.assert_allclose(gain, -log_f, atol=1e-10)


def test_algorithm_2_is_the_probability_of_satisfying_the_constraint(stochastic):
    # Monte Carlo truth: the share of C0-policy trajectories that never take a forbidden action
    g, _, cand = stochastic
    base = np.ones((g.mdp.n_states, g.mdp.n_actions), dtype=bool)
    picks = np.flatnonzero(cand.feasible)[[0, 5, 10]]
    sims = sample_demonstrations(g.mdp, 40000, base, rng=11)
    x, a = sims.states[:, :-1], sims.actions
    for k in picks:
        expected = (~cand.forbidden[x, a, k].any(axis=1)).mean()
        got = constraint_accrual(g.mdp, base, ~cand.forbidden[:, :, [k]])[0]
        assert got == pytest.approx(expected, abs=0.01)


def test_algorithm_1_feature_expectations_match_simulation():
    g = gridworld(4, 4, (0, 0), (3, 0), slip=0.1)
    mask = constraint_mask(g.mdp, [g.state(1, 0)], 0.25)
    features = np.eye(16)                                    # state-visit indicators
    got = expected_features(g.mdp, features, mask)
    sims = sample_demonstrations(g.mdp, 40000, mask, rng=2)
    counts = np.bincount(sims.states[:, :-1].ravel(), minlength=16) / sims.n
    np.testing.assert_allclose(got, counts, atol=0.03)


def test_exact_gain_equals_the_likelihood_difference(stochastic):
    g, demos, cand = stochastic
    base = np.ones((g.mdp.n_states, g.mdp.n_actions), dtype=bool)
    picks = np.flatnonzero(cand.feasible)[:4]
    log_f, gain = rank_candidates(g.mdp, demos, cand.forbidden[:, :, picks])
    l0 = demonstration_log_likelihood(g.mdp, demos, base)
    for k, gk in zip(picks, gain):
        l1 = demonstration_log_likelihood(g.mdp, demos, base & ~cand.forbidden[:, :, k])
        assert gk == pytest.approx((l1 - l0) / demos.n, abs=1e-9)
    starts = demos.states[:, 0]
    V0, V = log_partition(g.mdp, base)[starts, 0], log_partition(g.mdp, ~cand.forbidden[:, :, picks])[starts]
    np.testing.assert_allclose(log_f, (V - V0[:, None]).mean(axis=0), atol=1e-12)


def test_bad_inputs_raise_clear_errors(stochastic):
    g, demos, cand = stochastic
    with pytest.raises(ValueError, match="masks"):
        log_partition(g.mdp, np.ones((3, 9, 2), dtype=bool))
    with pytest.raises(ValueError, match="base_mask"):
        value_ratio(g.mdp, np.ones((30, 9, 2), dtype=bool), ~cand.forbidden)
    with pytest.raises(ValueError, match="criterion"):
        greedy_inference(g.mdp, demos, cand, 2, criterion="best")
    with pytest.raises(ValueError, match="rounds"):
        greedy_inference(g.mdp, demos, cand, -1)
    with pytest.raises(ValueError, match="features"):
        expected_features(g.mdp, np.ones((4, 2)))
    nothing = np.zeros((g.mdp.n_states, g.mdp.n_actions), dtype=bool)
    with pytest.raises(ValueError, match="base_mask"):
        rank_candidates(g.mdp, demos, cand.forbidden, nothing)
    assert soft_policy(g.mdp, nothing).sum() == 0


def test_algorithm_agreement_and_summary(stochastic):
    from mutual.constraints.backup import algorithm_agreement
    g, demos, cand = stochastic
    r = algorithm_agreement(g.mdp, demos, cand)
    assert r["alg34"] < 1e-10 and r["same_ranking"] and r["alg23"] > 1e-3
    result = greedy_inference(g.mdp, demos, cand, 3)
    first = result.chosen[0]
    s = result.summary([first], [first])
    assert s["recovered_at"] == 1 and s["next_untrue"] and s["F_next"] == pytest.approx(result.F[1])
    assert result.summary([first, -1], [first])["recovered_at"] == "not reached"


def test_compiled_engine_stays_float64_over_many_blocks():
    # blocks run on worker threads; each must run in float64 (jax's x64 switch is thread-local)
    g = gridworld(6, 5, (0, 0), (5, 0), slip=0.1)
    rng = np.random.default_rng(5)
    masks = rng.random((30, 9, 300)) < 0.9
    a, b = log_partition(g.mdp, masks, engine="numpy"), log_partition(g.mdp, masks, engine="jax")
    np.testing.assert_array_equal(np.isneginf(a), np.isneginf(b))
    np.testing.assert_allclose(a[np.isfinite(a)], b[np.isfinite(b)], rtol=1e-13, atol=1e-13)


G = gridworld(4, 4, (0, 0), (3, 0))
MDP0 = G.mdp
DEMOS = sample_demonstrations(MDP0, 5, rng=0)
CAND = constraint_candidates(MDP0, DEMOS)
X, A = MDP0.n_states, MDP0.n_actions


CASES = [
    # backups (Algorithms 3-4)
    (log_partition, (MDP0, np.ones((3, A, 2), dtype=bool)), {}, ValueError, "masks"),
    (log_partition, (MDP0, np.ones((X, A))), {}, ValueError, "masks"),
    (log_partition, (MDP0, np.ones((X, A), dtype=bool)), dict(engine="gpu"), ValueError, "engine"),
    (rank_candidates, (MDP0, DEMOS, np.ones((X, A - 1, 2), dtype=bool)), {}, ValueError, "forbidden"),
    (rank_candidates, (MDP0, DEMOS, CAND.forbidden, np.zeros((X, A), dtype=bool)), {}, ValueError, "base_mask"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i:02d}-{case[0].__name__}" for i, case in enumerate(CASES)])
def test_bad_input_raises_a_clear_error(fn, args, kwargs, error, phrase):
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value), f"message {str(info.value)!r} should mention {phrase!r}"
