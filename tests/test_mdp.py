"""The tabular MDP, its soft Bellman backup and the demonstrations format, each
checked against an independent truth (a reference recursion, the `imitation`
library's numbers, brute-force enumeration, finite differences)."""

import itertools

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.special import logsumexp

from mutual.constraints.mdp import MDP, soft_bellman_backup, soft_policy
from mutual.constraints.demonstrations import (check_demonstrations, demonstration_log_likelihood, Demonstrations, load_demonstrations, sample_demonstrations, write_demonstrations)
from mutual.constraints.gridworld import GRID_ACTIONS, gridworld


def random_mdp(seed=0, X=5, A=3, T=4):
    rng = np.random.default_rng(seed)
    S = rng.random((X, A, X))
    S /= S.sum(axis=-1, keepdims=True)
    return MDP(S, rng.normal(size=(X, A)), T, terminal_reward=rng.normal(size=X))


def reference_values(S, r, w, T):
    """A plain, loop-by-loop soft value recursion (eqs. 2.17-2.18)."""
    X, A, _ = S.shape
    V = [None] * (T + 1)
    V[T] = w
    for t in range(T - 1, -1, -1):
        V[t] = np.array([logsumexp([r[x, a] + S[x, a] @ V[t + 1] for a in range(A)]) for x in range(X)])
    return np.array(V)


def test_soft_values_match_imitation_mce_partition_fh():
    # imitation.algorithms.mce_irl.mce_partition_fh: reward per state at t = 0..H-1, no terminal value
    rng = np.random.default_rng(0)
    S = rng.random((5, 3, 5))
    S /= S.sum(axis=-1, keepdims=True)
    r = rng.normal(size=5)
    expected = [5.9070925968, 6.8142493497, 3.6537944598, 4.2646328761, 5.9126550185]
    for transitions in (S, sp.csr_matrix(S.reshape(15, 5))):
        V, _ = soft_bellman_backup(MDP(transitions, r, 4))
        np.testing.assert_allclose(V[0], expected, atol=1e-9)


def test_soft_values_match_reference_recursion():
    mdp = random_mdp(3, X=6, A=4, T=7)
    V, Q = soft_bellman_backup(mdp)
    np.testing.assert_allclose(V, reference_values(mdp.dense_transitions(), mdp.reward, mdp.terminal_reward, 7),
                               rtol=1e-12)
    np.testing.assert_allclose(logsumexp(Q, axis=2), V[:-1], rtol=1e-12)


def test_log_z_equals_brute_force_enumeration_for_deterministic_dynamics():
    rng = np.random.default_rng(1)
    X, A, T = 4, 3, 5
    nxt = rng.integers(0, X, size=(X, A))
    S = np.zeros((X, A, X))
    S[np.arange(X)[:, None], np.arange(A), nxt] = 1.0
    r, w = rng.normal(size=(X, A)), rng.normal(size=X)
    mask = rng.random((X, A)) < 0.75
    mask[:, 0] = True
    V, _ = soft_bellman_backup(MDP(S, r, T, terminal_reward=w), mask)
    for x0 in range(X):
        returns = []
        for seq in itertools.product(range(A), repeat=T):
            x, R = x0, 0.0
            for a in seq:
                if not mask[x, a]:
                    break
                R, x = R + r[x, a], nxt[x, a]
            else:
                returns.append(R + w[x])
        assert V[0, x0] == pytest.approx(logsumexp(returns), rel=1e-12)


def test_backup_is_stable_for_long_horizons_and_large_rewards():
    g = gridworld(5, 5, (0, 0), (4, 4), horizon=1000, miss_penalty=1e4)
    mdp = MDP(g.mdp.dense_transitions(), 500.0 * g.mdp.reward, 1000, terminal_reward=g.mdp.terminal_reward,
              initial=g.mdp.initial)
    V, Q = soft_bellman_backup(mdp)
    assert np.all(np.isfinite(V)) and not np.isnan(Q).any()
    pi = soft_policy(mdp)
    np.testing.assert_allclose(pi.sum(axis=2), 1.0, atol=1e-12)


def test_gradient_of_log_z_is_the_expected_visitation():
    # d log Z / d r(x, a) = expected number of visits of (x, a): Algorithm 1's feature expectation
    from mutual.constraints.backup import state_action_visitation
    mdp = random_mdp(4, X=4, A=3, T=5)
    mask = np.ones((4, 3), dtype=bool)
    mask[1, 2] = False
    occ = state_action_visitation(mdp, mask).sum(axis=0)
    eps = 1e-6
    for x, a in [(0, 0), (2, 1), (3, 2)]:
        grads = []
        for sign in (1, -1):
            r = mdp.reward.copy()
            r[x, a] += sign * eps
            V, _ = soft_bellman_backup(MDP(mdp.transitions.reshape(4, 3, 4), r, 5, mdp.terminal_reward), mask)
            grads.append(mdp.initial @ V[0])
        assert (grads[0] - grads[1]) / (2 * eps) == pytest.approx(occ[x, a], abs=1e-7)


def test_forbidden_states_give_minus_infinity_without_nan():
    S = np.zeros((3, 2, 3))
    S[0, 0, 1] = S[0, 1, 2] = S[1, :, 1] = S[2, :, 2] = 1.0
    S[0, 1] = [0.0, 0.5, 0.5]
    mask = np.ones((3, 2), dtype=bool)
    mask[2] = False                       # state 2 has no allowed action
    V, Q = soft_bellman_backup(MDP(S, np.zeros((3, 2)), 3), mask)
    assert np.isneginf(V[:-1, 2]).all() and np.isneginf(Q[:-1, 0, 1]).all()  # at t = T-1 x_T = 2 is fine
    assert not np.isnan(V).any() and np.isfinite(V[:, :2]).all()


def test_gridworld_transitions_and_rewards():
    g = gridworld(4, 3, (0, 0), (3, 0), slip=0.1)
    S = g.mdp.dense_transitions()
    np.testing.assert_allclose(S.sum(axis=2), 1.0)
    E, loiter = GRID_ACTIONS.index("E"), GRID_ACTIONS.index("loiter")
    x = g.state(1, 1)                      # interior: 0.9 ahead, 0.1 / 7 to each other neighbour
    assert S[x, E, g.state(2, 1)] == pytest.approx(0.9)
    assert S[x, E, g.state(0, 0)] == pytest.approx(0.1 / 7)
    assert S[x, loiter, x] == 1.0
    corner = g.state(0, 0)                 # commanded off-grid: stay; slips only onto the grid
    W = GRID_ACTIONS.index("W")
    assert S[corner, W, corner] == pytest.approx(0.9)
    assert S[corner, W, g.state(1, 0)] == pytest.approx(0.1 / 3)
    assert S[corner, E, corner] == 0.0
    assert g.mdp.reward[x, E] == -1.0 and g.mdp.reward[x, 1] == pytest.approx(-np.sqrt(2))
    assert g.mdp.reward[x, loiter] == 0.0
    assert g.mdp.terminal_reward[g.state(3, 0)] == 0.0 and g.mdp.terminal_reward[x] < 0
    sparse = gridworld(4, 3, (0, 0), (3, 0), slip=0.1, sparse=True)
    np.testing.assert_array_equal(sparse.mdp.dense_transitions(), S)


def test_sampled_demonstrations_follow_the_policy():
    g = gridworld(3, 3, (0, 0), (2, 0), slip=0.2, horizon=3)
    mdp = g.mdp
    demos = sample_demonstrations(mdp, 20000, rng=5)
    pi0 = soft_policy(mdp)[0, g.state(0, 0)]
    freq = np.bincount(demos.actions[:, 0], minlength=9) / demos.n
    np.testing.assert_allclose(freq, pi0, atol=0.015)
    check_demonstrations(mdp, demos)
    again = sample_demonstrations(mdp, 50, rng=5)
    np.testing.assert_array_equal(again.states, sample_demonstrations(mdp, 50, rng=5).states)


def test_demonstrations_csv_round_trip(tmp_path):
    g = gridworld(4, 4, (0, 0), (3, 0))
    demos = sample_demonstrations(g.mdp, 7, rng=1)
    path = write_demonstrations(tmp_path / "demos.csv", demos)
    back = load_demonstrations(path, g.mdp)
    np.testing.assert_array_equal(back.states, demos.states)
    np.testing.assert_array_equal(back.actions, demos.actions)
    assert demonstration_log_likelihood(g.mdp, back) == demonstration_log_likelihood(g.mdp, demos)


@pytest.mark.parametrize("edit, message", [
    (lambda df: df.assign(state=df["state"].where(df.index != 3, 99)), "unknown state"),
    (lambda df: df.assign(action=df["action"].where(df.index != 2, 12)), "unknown action"),
    (lambda df: df.drop(columns="action"), "missing column 'action'"),
    (lambda df: df.assign(t=df["t"].where(df.index != 2, 7)), "t must run"),
])
def test_loader_rejects_bad_files(tmp_path, edit, message):
    import pandas as pd
    g = gridworld(4, 4, (0, 0), (3, 0))
    path = write_demonstrations(tmp_path / "demos.csv", sample_demonstrations(g.mdp, 3, rng=2))
    edit(pd.read_csv(path)).to_csv(path, index=False)
    with pytest.raises(ValueError, match=message):
        load_demonstrations(path, g.mdp)


def test_loader_rejects_impossible_transitions(tmp_path):
    g = gridworld(4, 4, (0, 0), (3, 0), slip=0.0)
    states = np.array([[0, 1, 2]])
    actions = np.array([[GRID_ACTIONS.index("E"), GRID_ACTIONS.index("W")]])   # W from 1 cannot reach 2
    path = write_demonstrations(tmp_path / "demos.csv", Demonstrations(states, actions))
    with pytest.raises(ValueError, match="zero probability"):
        load_demonstrations(path, g.mdp)


@pytest.mark.parametrize("kwargs, message", [
    (dict(transitions=-np.ones((2, 1, 2))), "transitions"),
    (dict(transitions=np.full((2, 1, 2), 0.3)), "sum to 1"),
    (dict(transitions=np.ones((2, 1, 3)) / 3), "transitions"),
    (dict(transitions=sp.csr_matrix(np.ones((3, 2)) / 2)), "transitions"),
    (dict(reward=np.zeros((3, 1))), "reward"),
    (dict(reward=np.array([[np.nan], [0.0]])), "reward"),
    (dict(terminal_reward=np.array([np.inf, 0.0])), "terminal_reward"),
    (dict(horizon=0), "horizon"),
    (dict(horizon=2.5), "horizon"),
    (dict(initial=np.array([0.7, 0.7])), "initial"),
])
def test_bad_mdp_inputs_raise_clear_errors(kwargs, message):
    args = dict(transitions=np.ones((2, 1, 2)) / 2, reward=np.zeros((2, 1)), horizon=3)
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        MDP(**args)


@pytest.mark.parametrize("kwargs, message", [
    (dict(width=1), "width"), (dict(start=(9, 0)), "start"), (dict(goal=(0, -1)), "goal"), (dict(slip=1.5), "slip"),
])
def test_bad_gridworld_inputs_raise_clear_errors(kwargs, message):
    args = dict(width=4, height=4, start=(0, 0), goal=(3, 0))
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        gridworld(**args)


def test_bad_masks_and_demonstrations_raise_clear_errors():
    g = gridworld(3, 3, (0, 0), (2, 0))
    with pytest.raises(ValueError, match="mask"):
        soft_bellman_backup(g.mdp, np.ones((9, 9)))
    with pytest.raises(ValueError, match="mask"):
        soft_bellman_backup(g.mdp, np.ones((9, 8), dtype=bool))
    with pytest.raises(ValueError, match="states/actions"):
        Demonstrations(np.zeros((2, 3), dtype=int), np.zeros((2, 3), dtype=int))
    with pytest.raises(ValueError, match="exceed the horizon"):
        check_demonstrations(g.mdp, Demonstrations(np.zeros((1, 40), dtype=int), np.full((1, 39), 8)))
