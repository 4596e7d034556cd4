"""The discrete loop's algorithms against brute force: every trajectory (and every deterministic policy)
of tiny MDPs enumerated, the maximum-entropy distribution normalised by hand, and Monte Carlo."""

import itertools

import numpy as np
import pytest

from mutual.constraints.mdp import MDP, soft_bellman_backup, soft_policy
from mutual.cycle.mdp_legibility import legibility_weights, legible_backup, legible_objective
from mutual.cycle.observer import (expected_log_odds, log_odds_paths, posterior_paths, step_log_ratio,
                                   time_to_confidence)
from mutual.cycle.outcomes import policy_outcomes, rollout_outcomes, sample_rollouts
from mutual.constraints.demonstrations import Demonstrations

X, A, T = 3, 2, 3


def tiny_mdp(seed, deterministic=False):
    rng = np.random.default_rng(seed)
    if deterministic:
        S = np.zeros((X, A, X))
        S[np.arange(X)[:, None], np.arange(A)[None, :], rng.integers(0, X, (X, A))] = 1.0
    else:
        S = rng.random((X, A, X)) + 0.05
        S /= S.sum(axis=2, keepdims=True)
    p0 = np.zeros(X)
    p0[0] = 1.0
    return MDP(S, rng.normal(size=(X, A)), T, terminal_reward=rng.normal(size=X), initial=p0)


def constraint(mdp):
    """Forbid action 1 in state 0 and action 0 in state 2 (C1); C0 allows everything."""
    mask = np.ones((X, A), dtype=bool)
    mask[0, 1] = mask[2, 0] = False
    return mask


def trajectories(mdp):
    """Every (states, actions, probability-under-dynamics-only factor) of T steps from x_0 = 0."""
    S = mdp.dense_transitions()
    for actions in itertools.product(range(A), repeat=T):
        for nxt in itertools.product(range(X), repeat=T):
            states = (0,) + nxt
            dyn = np.prod([S[states[t], actions[t], states[t + 1]] for t in range(T)])
            if dyn > 0:
                yield np.array(states), np.array(actions), dyn


def reward(mdp, states, actions):
    return sum(mdp.reward[states[t], actions[t]] for t in range(T)) + mdp.terminal_reward[states[-1]]


def random_policy(rng, mask=None):
    pi = rng.random((T, X, A)) + 0.1
    if mask is not None:
        pi = pi * mask
    return pi / pi.sum(axis=2, keepdims=True)


@pytest.mark.parametrize("seed", range(3))
def test_policy_outcomes_match_enumeration(seed):
    mdp = tiny_mdp(seed)
    rng = np.random.default_rng(seed)
    pi, allowed, avoid = random_policy(rng), constraint(mdp), [1]
    expected = {"p_break": 0.0, "p_enter": 0.0, "p_either": 0.0, "expected_reward": 0.0}
    for states, actions, dyn in trajectories(mdp):
        p = dyn * np.prod([pi[t, states[t], actions[t]] for t in range(T)])
        broke = not all(allowed[states[t], actions[t]] for t in range(T))
        entered = any(s in avoid for s in states)
        expected["p_break"] += p * broke
        expected["p_enter"] += p * entered
        expected["p_either"] += p * (broke or entered)
        expected["expected_reward"] += p * reward(mdp, states, actions)
    got = policy_outcomes(mdp, pi, allowed=allowed, forbidden_states=avoid)
    for key, value in expected.items():
        assert got[key] == pytest.approx(value, abs=1e-12), key


def test_sampled_rollouts_agree_with_the_forward_pass():
    mdp = tiny_mdp(7)
    pi = random_policy(np.random.default_rng(7))
    exact = policy_outcomes(mdp, pi, allowed=constraint(mdp), forbidden_states=[2])
    sampled = rollout_outcomes(mdp, sample_rollouts(mdp, pi, 40000, rng=1), allowed=constraint(mdp), forbidden_states=[2])
    for key in ("p_break", "p_enter", "p_either"):
        se = np.sqrt(exact[key] * (1 - exact[key]) / 40000)
        assert abs(sampled[key] - exact[key]) < 5 * se + 1e-9, key
    assert sampled["expected_reward"] == pytest.approx(exact["expected_reward"], abs=0.05)


def maxent_prefix_log_likelihood(mdp, mask):
    """For deterministic dynamics: log P(prefix | C) = log sum over feasible completions exp(R) - log Z_C,
    by enumeration (the maximum-entropy distribution of eq. 2.9, equal to eq. 2.19 here)."""
    table, Z = {}, 0.0
    for states, actions, dyn in trajectories(mdp):
        if all(mask[states[t], actions[t]] for t in range(T)):
            weight = np.exp(reward(mdp, states, actions))
            Z += weight
            for t in range(T + 1):
                key = tuple(actions[:t])
                table[key] = table.get(key, 0.0) + weight
    return {k: np.log(v) - np.log(Z) for k, v in table.items()}


@pytest.mark.parametrize("seed", range(3))
def test_observer_log_ratio_equals_brute_force_prefix_likelihoods(seed):
    mdp = tiny_mdp(seed, deterministic=True)
    c1 = constraint(mdp)
    ll1, ll0 = maxent_prefix_log_likelihood(mdp, c1), maxent_prefix_log_likelihood(mdp, np.ones((X, A), bool))
    ratio = step_log_ratio(mdp, c1)
    for states, actions, _ in trajectories(mdp):
        if not all(c1[states[t], actions[t]] for t in range(T)):
            continue
        path = log_odds_paths(ratio, Demonstrations(states[None], actions[None]), prior=0.5)[0]
        brute = [ll1[tuple(actions[:t])] - ll0[tuple(actions[:t])] for t in range(T + 1)]
        np.testing.assert_allclose(path, brute, atol=1e-10)


@pytest.mark.parametrize("seed", range(3))
def test_expected_log_odds_and_refutation_match_enumeration(seed):
    mdp = tiny_mdp(seed)
    ratio = step_log_ratio(mdp, constraint(mdp))
    pi = random_policy(np.random.default_rng(seed + 10))          # breaks C1 with positive probability
    mean, refuted = expected_log_odds(mdp, pi, ratio, prior=0.3)
    alive, acc, dead = np.zeros(T + 1), np.zeros(T + 1), np.zeros(T + 1)
    for states, actions, dyn in trajectories(mdp):
        p = dyn * np.prod([pi[t, states[t], actions[t]] for t in range(T)])
        steps = np.array([ratio[t, states[t], actions[t]] for t in range(T)])
        for t in range(T + 1):
            if np.all(np.isfinite(steps[:t])):
                alive[t] += p
                acc[t] += p * steps[:t].sum()
            else:
                dead[t] += p
    np.testing.assert_allclose(refuted, dead, atol=1e-12)
    np.testing.assert_allclose(mean, np.log(0.3 / 0.7) + acc / alive, atol=1e-10)


@pytest.mark.parametrize("seed", range(4))
def test_final_log_ratio_telescopes_to_minus_log_F(seed):
    """E_pi[log Lambda_{0:T}] = -log F_C1(x_0) for every policy that respects C1 (derivation in
    mutual.cycle.mdp_legibility), counted by enumeration."""
    mdp = tiny_mdp(seed)
    c1 = constraint(mdp)
    ratio = step_log_ratio(mdp, c1)
    V1, V0 = soft_bellman_backup(mdp, c1)[0], soft_bellman_backup(mdp)[0]
    pi = random_policy(np.random.default_rng(seed), c1)
    total = 0.0
    for states, actions, dyn in trajectories(mdp):
        p = dyn * np.prod([pi[t, states[t], actions[t]] for t in range(T)])
        if p > 0:
            total += p * sum(ratio[t, states[t], actions[t]] for t in range(T))
    assert total == pytest.approx(V0[0, 0] - V1[0, 0], abs=1e-12)
    assert legible_objective(mdp, pi, ratio, 1.0, np.ones(T))["legibility"] == pytest.approx(total, abs=1e-12)


@pytest.mark.parametrize("alpha", [0.3, 1.0, 4.0])
def test_final_ratio_legible_policy_is_the_plain_policy(alpha):
    mdp = tiny_mdp(5)
    c1 = constraint(mdp)
    _, policy = legible_backup(mdp, c1, step_log_ratio(mdp, c1), alpha, legibility_weights(T, "final"))
    np.testing.assert_allclose(policy, soft_policy(mdp, c1), atol=1e-12)


@pytest.mark.parametrize("alpha", [0.25, 1.0])
def test_soft_legible_backup_equals_the_gibbs_optimum_over_all_trajectories(alpha):
    """Deterministic dynamics: max_q E_q[g] + alpha H(q) = alpha log sum_xi exp(g / alpha) with
    g = sum_t w_t l_t + alpha R, attained by q* proportional to exp(g / alpha); l from brute-force likelihoods."""
    mdp = tiny_mdp(3, deterministic=True)
    c1 = constraint(mdp)
    w = legibility_weights(T, "anticipatory")
    ll1, ll0 = maxent_prefix_log_likelihood(mdp, c1), maxent_prefix_log_likelihood(mdp, np.ones((X, A), bool))
    U, policy = legible_backup(mdp, c1, step_log_ratio(mdp, c1), alpha, w)
    g, q = [], []
    for states, actions, _ in trajectories(mdp):
        if not all(c1[states[t], actions[t]] for t in range(T)):
            continue
        prefix = [ll1[tuple(actions[:t])] - ll0[tuple(actions[:t])] for t in range(T + 1)]
        steps = np.diff(prefix)
        g.append(w @ steps + alpha * reward(mdp, states, actions))
        q.append(np.prod([policy[t, states[t], actions[t]] for t in range(T)]))
    g, q = np.array(g), np.array(q)
    best = alpha * np.log(np.sum(np.exp(g / alpha)))
    assert alpha * U[0, 0] == pytest.approx(best, abs=1e-10)
    np.testing.assert_allclose(q, np.exp(g / alpha) / np.sum(np.exp(g / alpha)), atol=1e-10)


@pytest.mark.parametrize("seed", range(2))
def test_hard_legible_backup_beats_every_deterministic_policy(seed):
    """Stochastic dynamics: the hard backup's value equals the best of all |A|^(X T) deterministic
    Markov policies, each evaluated exactly by enumerating trajectories."""
    mdp = tiny_mdp(seed)
    c1 = constraint(mdp)
    ratio = step_log_ratio(mdp, c1)
    w = legibility_weights(T, "anticipatory")
    alpha = 0.5
    U, policy = legible_backup(mdp, c1, ratio, alpha, w, soft=False)
    allowed = [[a for a in range(A) if c1[x, a]] for x in range(X)]
    best = -np.inf
    for choice in itertools.product(*[allowed[x] for _ in range(T) for x in range(X)]):
        pi = np.zeros((T, X, A))
        pi[np.repeat(np.arange(T), X), np.tile(np.arange(X), T), choice] = 1.0
        value = 0.0
        for states, actions, dyn in trajectories(mdp):
            p = dyn * np.prod([pi[t, states[t], actions[t]] for t in range(T)])
            if p > 0:
                value += p * (sum(w[t] * ratio[t, states[t], actions[t]] for t in range(T))
                              + alpha * reward(mdp, states, actions))
        best = max(best, value)
    assert U[0, 0] == pytest.approx(best, abs=1e-10)
    assert legible_objective(mdp, policy, ratio, alpha, w)["objective"] == pytest.approx(best, abs=1e-10)


def test_anticipatory_legibility_moves_evidence_earlier_at_a_cost():
    """On the thesis's gridworld the legible robot gains expected log-odds early and gives up soft task value
    E[R] + H (which the plain robot P_C maximises within C), while the total evidence stays -log F."""
    from mutual.constraints.chance import constraint_mask
    from mutual.constraints.gridworld import gridworld

    grid = gridworld(5, 5, start=(0, 2), goal=(4, 2), slip=0.1)
    mask = constraint_mask(grid.mdp, [grid.state(2, 2)], 0.25)
    ratio = step_log_ratio(grid.mdp, mask)
    w = legibility_weights(grid.mdp.horizon)
    plain = soft_policy(grid.mdp, mask)
    legible = legible_backup(grid.mdp, mask, ratio, 0.05, w)[1]
    lp, ll = (legible_objective(grid.mdp, p, ratio, 1.0, w) for p in (plain, legible))
    assert ll["legibility"] > lp["legibility"] + 1e-3
    assert ll["reward"] + ll["entropy"] < lp["reward"] + lp["entropy"]
    mean_plain, mean_legible = (expected_log_odds(grid.mdp, p, ratio)[0] for p in (plain, legible))
    assert mean_legible[-1] == pytest.approx(mean_plain[-1], abs=1e-9)    # the total is fixed (-log F)


def test_time_to_confidence_and_posteriors():
    post = np.array([[0.5, 0.9, 0.96, 0.99], [0.5, 0.6, 0.7, 0.8]])
    np.testing.assert_array_equal(time_to_confidence(post, 0.95), [2.0, np.nan])
    mdp = tiny_mdp(1, deterministic=True)
    ratio = step_log_ratio(mdp, constraint(mdp))
    demos = sample_rollouts(mdp, soft_policy(mdp, constraint(mdp)), 5, rng=0)
    p = posterior_paths(ratio, demos, prior=0.2)
    assert np.allclose(p[:, 0], 0.2) and np.all((p >= 0) & (p <= 1))


def test_observer_study_carries_the_log_odds_across_episodes():
    from scipy.special import logit
    from mutual.cycle.discrete import observer_study

    mdp = tiny_mdp(2)
    c1 = constraint(mdp)
    policy = soft_policy(mdp, c1)
    table, curves = observer_study(mdp, {"plain": policy}, c1, 50, 2, np.random.default_rng(3), level=0.8, prior=0.4)
    rolls = sample_rollouts(mdp, policy, 100, np.random.default_rng(3))
    gained = log_odds_paths(step_log_ratio(mdp, c1), rolls, 0.4) - logit(0.4)
    first, second = gained[0::2], gained[1::2]
    path = np.concatenate([first, first[:, -1:] + second[:, 1:]], axis=1) + logit(0.4)
    np.testing.assert_allclose(curves["plain"]["mean_posterior"], (1 / (1 + np.exp(-path))).mean(axis=0), atol=1e-12)
    expected = time_to_confidence(1 / (1 + np.exp(-path)), 0.8)
    np.testing.assert_array_equal(curves["plain"]["time"], expected)
    assert table["p_confident_ep2"].iloc[0] == np.mean(expected <= 2 * T)


def test_compare_robots_and_alpha_sweep_are_the_forward_passes():
    from mutual.cycle.discrete import alpha_sweep, compare_robots
    from mutual.cycle.learning import ConstraintSet
    from mutual.constraints.gridworld import gridworld

    grid = gridworld(5, 5, start=(0, 2), goal=(4, 2), slip=0.1)
    truth = ConstraintSet([grid.state(2, 2)], 0.25)
    robots = compare_robots(grid.mdp, truth, {"none": None, "truth": truth.mask(grid.mdp)}).set_index("robot")
    direct = policy_outcomes(grid.mdp, soft_policy(grid.mdp), allowed=truth.mask(grid.mdp), forbidden_states=truth.states)
    assert robots.loc["none", "p_break"] == pytest.approx(direct["p_break"]) and direct["p_break"] > 0.1
    assert robots.loc["truth", "p_break"] == 0.0
    sweep = alpha_sweep(grid.mdp, truth.mask(grid.mdp), truth.mask(grid.mdp), [np.inf, 1.0, 0.05])
    assert sweep["mean_log_odds_over_time"].is_monotonic_increasing                      # more legible as alpha falls
    assert np.allclose(sweep["p_break"], 0.0)
