"""Property-based tests (hypothesis) of the chapter 2-3 core on random small problems, each against an
independent truth: brute-force enumeration of every trajectory, the other algorithm, a plain loop over
eq. (3.3), exhaustive scoring. Derandomised with few examples, so the run time stays bounded."""

import numpy as np
from hypothesis import given, settings, strategies as st

from mutual.constraints.backup import log_partition, rank_candidates, value_ratio
from mutual.constraints.bounds import gain_bounds
from mutual.constraints.candidates import constraint_candidates
from mutual.constraints.chance import constraint_mask, max_likelihood_thresholds, psi_star_by_loop
from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.feasibility import infeasible_candidates
from mutual.constraints.gridworld import gridworld
from mutual.constraints.inference import greedy_inference
from mutual.constraints.mdp import MDP, soft_bellman_backup
from mutual.constraints.noncausal import enumerate_trajectories, soft_value_by_enumeration

FEW = settings(max_examples=15, deadline=None, derandomize=True)


def random_mdp(seed, X, A, T, deterministic, sparse_allowed=True):
    rng = np.random.default_rng(seed)
    if deterministic:
        S = np.zeros((X, A, X))
        S[np.arange(X)[:, None], np.arange(A), rng.integers(0, X, size=(X, A))] = 1.0
    else:
        S = rng.random((X, A, X)) * (rng.random((X, A, X)) < 0.7)
        S[:, :, 0] += 1e-3                                           # every row reaches something
        S /= S.sum(axis=2, keepdims=True)
    allowed = rng.random((X, A)) < 0.8 if sparse_allowed else np.ones((X, A), dtype=bool)
    allowed[np.arange(X), rng.integers(0, A, size=X)] = True        # every state offers an action
    p0 = np.zeros(X)
    p0[0] = 1.0
    return MDP(S, rng.normal(size=(X, A)), T, terminal_reward=rng.normal(size=X), initial=p0, allowed=allowed)


sizes = dict(seed=st.integers(0, 10_000), X=st.integers(2, 3), A=st.integers(1, 3), T=st.integers(1, 3),
             deterministic=st.booleans())


@FEW
@given(**sizes)
def test_soft_backup_equals_enumeration_of_every_trajectory(seed, X, A, T, deterministic):
    mdp = random_mdp(seed, X, A, T, deterministic)
    V, _ = soft_bellman_backup(mdp)
    # the causal value is the entropy-regularised return over all trajectories (any dynamics) ...
    assert abs(soft_value_by_enumeration(mdp) - V[0, 0]) < 1e-9
    # ... and with deterministic dynamics log Z = log sum_xi exp(R(xi)) over feasible trajectories
    if deterministic:
        states, actions = enumerate_trajectories(mdp)
        S = mdp.dense_transitions()
        ok = (S[states[:, :-1], actions, states[:, 1:]] == 1).all(axis=1) & mdp.allowed[states[:, :-1], actions].all(axis=1)
        R = mdp.reward[states[:, :-1], actions].sum(axis=1) + mdp.terminal_reward[states[:, -1]]
        assert abs(np.log(np.exp(R[ok]).sum()) - V[0, 0]) < 1e-9
    assert abs(log_partition(mdp, mdp.allowed)[0, 0] - V[0, 0]) < 1e-9          # Algorithm 4, batched


@FEW
@given(**sizes, K=st.integers(1, 5))
def test_algorithm_3_equals_algorithm_4(seed, X, A, T, deterministic, K):
    mdp = random_mdp(seed, X, A, T, deterministic)
    rng = np.random.default_rng(seed + 1)
    base = rng.random((X, A)) < 0.9
    masks = base[:, :, None] & (rng.random((X, A, K)) < 0.8)
    V0 = log_partition(mdp, base)[:, 0]
    V = log_partition(mdp, masks)
    log_f = value_ratio(mdp, base, masks)
    alive = np.isfinite(V0)
    np.testing.assert_array_equal(np.isneginf(log_f[alive]), np.isneginf(V[alive]))
    np.testing.assert_allclose(np.exp(log_f[alive]), np.exp(V[alive] - V0[alive, None]), atol=1e-10)


@FEW
@given(seed=st.integers(0, 10_000), width=st.integers(3, 5), slip=st.sampled_from([0.0, 0.1, 0.3]),
       n=st.integers(1, 20), loiter=st.sampled_from(["goal", "anywhere"]))
def test_psi_star_equals_the_loop_over_eq_3_3(seed, width, slip, n, loiter):
    g = gridworld(width, 3, (0, 0), (width - 1, 0), slip=slip, loiter=loiter)
    demos = sample_demonstrations(g.mdp, n, rng=seed)
    loop = psi_star_by_loop(g.mdp.dense_transitions(), demos.states, demos.actions)
    np.testing.assert_array_equal(max_likelihood_thresholds(g.mdp, demos), loop)
    cand = constraint_candidates(g.mdp, demos)
    np.testing.assert_array_equal(cand.psi[cand.kind == "state"], loop)


@settings(max_examples=8, deadline=None, derandomize=True)
@given(seed=st.integers(0, 10_000), width=st.integers(4, 6), slip=st.sampled_from([0.0, 0.1]))
def test_infeasibility_filter_bounds_and_pruned_greedy_match_exhaustive_scoring(seed, width, slip):
    g = gridworld(width, 4, (0, 0), (width - 1, 0), slip=slip)
    truth = constraint_mask(g.mdp, [g.state(width // 2, 0)], 0.25 if slip else 0.0)
    demos = sample_demonstrations(g.mdp, 15, truth, rng=seed)
    cand = constraint_candidates(g.mdp, demos)
    base = np.ones((g.mdp.n_states, g.mdp.n_actions), dtype=bool)
    log_f, gain = rank_candidates(g.mdp, demos, cand.forbidden, base)
    dead = infeasible_candidates(g.mdp, demos, base, cand.forbidden_matrix)
    np.testing.assert_array_equal(dead, ~np.isfinite(gain))
    bound = gain_bounds(g.mdp, demos, base, cand.forbidden_matrix[:, ~dead])
    assert np.all(bound >= -log_f[~dead] - 1e-12)
    full = greedy_inference(g.mdp, demos, cand, 3)
    pruned = greedy_inference(g.mdp, demos, cand, 3, prune=True)
    assert pruned.chosen == full.chosen
    np.testing.assert_allclose(pruned.gains, full.gains, atol=1e-12)


@settings(max_examples=6, deadline=None, derandomize=True)
@given(seed=st.integers(0, 10_000), width=st.integers(3, 6), slip=st.sampled_from([0.0, 0.1, 0.2]),
       loiter=st.sampled_from(["goal", "anywhere"]))
def test_compiled_and_numpy_engines_agree(seed, width, slip, loiter):
    g = gridworld(width, 3, (0, 0), (width - 1, 0), slip=slip, loiter=loiter, sparse=bool(seed % 2))
    rng = np.random.default_rng(seed)
    masks = rng.random((g.mdp.n_states, g.mdp.n_actions, 7)) < 0.8
    a, b = log_partition(g.mdp, masks, engine="numpy"), log_partition(g.mdp, masks, engine="jax")
    np.testing.assert_array_equal(np.isneginf(a), np.isneginf(b))
    np.testing.assert_allclose(a[np.isfinite(a)], b[np.isfinite(b)], rtol=1e-12, atol=1e-12)
    demos = sample_demonstrations(g.mdp, 6, rng=seed)
    for x, y in zip(rank_candidates(g.mdp, demos, ~masks, engine="numpy"),
                    rank_candidates(g.mdp, demos, ~masks, engine="jax")):
        np.testing.assert_array_equal(np.isfinite(x), np.isfinite(y))
        np.testing.assert_allclose(x[np.isfinite(x)], y[np.isfinite(y)], atol=1e-11)
