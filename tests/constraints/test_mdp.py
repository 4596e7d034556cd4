"""The tabular MDP and its soft Bellman backup (eqs. 2.5-2.7), checked against the `imitation` library's
numbers, a reference recursion, brute-force enumeration of every trajectory and finite differences;
its bad inputs (a table of input -> message)."""

import itertools

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.special import logsumexp

from mutual.constraints.gridworld import gridworld
from mutual.constraints.mdp import MDP, soft_bellman_backup, soft_policy


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


def test_dense_transitions_round_trip_through_the_mdp():
    g = gridworld(3, 3, (0, 0), (2, 0))
    again = MDP(g.mdp.transitions, g.mdp.reward, g.mdp.horizon, g.mdp.terminal_reward, g.mdp.initial, g.mdp.allowed)
    np.testing.assert_array_equal(again.dense_transitions(), g.mdp.dense_transitions())


@pytest.mark.parametrize("dtype", [np.float32, np.float16])
def test_a_lower_precision_slip_or_transition_matrix_is_stochastic(dtype):
    grid = gridworld(9, 9, (0, 0), (8, 0), slip=dtype(0.1))
    assert grid.slip == float(dtype(0.1)) and grid.mdp.transitions.dtype == np.float64
    reference = gridworld(9, 9, (0, 0), (8, 0)).mdp
    S = reference.dense_transitions().astype(dtype)
    for given in (S, sp.csr_matrix(S.reshape(-1, 81))) if dtype == np.float32 else (S,):
        mdp = MDP(given, reference.reward, reference.horizon)
        sums = np.asarray(mdp.transitions.sum(axis=1)).ravel()
        assert np.abs(sums - 1).max() <= 1e-15


@pytest.mark.parametrize("dtype, off", [(np.float32, 1e-2), (np.float64, 1e-8), (np.float16, 0.2)])
def test_a_matrix_whose_rows_do_not_sum_to_one_in_its_own_precision_is_refused(dtype, off):
    reference = gridworld(5, 4, (0, 0), (4, 0)).mdp
    S = reference.dense_transitions().astype(dtype)
    S[2, 1, :] *= dtype(1 + off)
    with pytest.raises(ValueError, match=r"S\(2, 1, .\) sums to"):
        MDP(S, reference.reward, reference.horizon)


G = gridworld(4, 4, (0, 0), (3, 0))
MDP0 = G.mdp
X, A = MDP0.n_states, MDP0.n_actions
SIMPLE = dict(transitions=np.ones((2, 1, 2)) / 2, reward=np.zeros((2, 1)), horizon=3)


def _mdp(**kwargs):
    return MDP(**{**SIMPLE, **kwargs})


CASES = [
    # MDP
    (_mdp, (), dict(transitions=-np.ones((2, 1, 2))), ValueError, "transitions"),
    (_mdp, (), dict(transitions=np.full((2, 1, 2), 0.3)), ValueError, "sum to 1"),
    (_mdp, (), dict(transitions="S"), ValueError, "transitions"),
    (_mdp, (), dict(transitions=sp.csr_matrix(np.ones((3, 2)) / 2)), ValueError, "transitions"),
    (_mdp, (), dict(reward=np.array([[np.nan], [0.0]])), ValueError, "reward"),
    (_mdp, (), dict(reward=np.full((2, 1), 1e200)), ValueError, "exceeds"),
    (_mdp, (), dict(horizon=True), ValueError, "horizon"),
    (_mdp, (), dict(initial=np.array([0.7, 0.7])), ValueError, "initial"),
    (_mdp, (), dict(allowed=np.ones((2, 1))), ValueError, "allowed"),
    (_mdp, (), dict(allowed=np.array([[True], [False]])), ValueError, "offers no action"),
    (soft_bellman_backup, (MDP0, np.ones((X, A, 2), dtype=bool)), {}, ValueError, "mask"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i:02d}-{case[0].__name__}" for i, case in enumerate(CASES)])
def test_bad_input_raises_a_clear_error(fn, args, kwargs, error, phrase):
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value), f"message {str(info.value)!r} should mention {phrase!r}"


def test_soft_policy_stays_normalised_for_huge_penalties():
    # rows used to sum to 2.7 at a penalty of 1e16; relative to the row maximum they sum to 1
    from mutual.constraints.mdp import soft_policy
    for penalty in (1e12, 1e16, 1e90):
        g = gridworld(4, 4, (0, 0), (3, 0), miss_penalty=penalty)
        pi = soft_policy(g.mdp)
        live = pi.sum(axis=2) > 0
        np.testing.assert_allclose(pi.sum(axis=2)[live], 1.0, atol=1e-12)
        assert live.all() and np.all(np.isfinite(pi))
