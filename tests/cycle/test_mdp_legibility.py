"""The MDP counterpart of chapter 6's legible objective: the final log ratio telescopes to -log F, the soft
legible backup is the Gibbs optimum over all trajectories, the hard one beats every deterministic policy,
and anticipation moves evidence earlier at a cost; bad inputs (a table)."""

import itertools

import numpy as np
import pytest

from mutual.constraints.gridworld import gridworld
from mutual.constraints.mdp import soft_bellman_backup, soft_policy
from mutual.cycle.mdp_legibility import legibility_weights, legible_backup, legible_objective
from mutual.cycle.observer import expected_log_odds, step_log_ratio

from helpers.tiny_mdps import (A, T, X, constraint, maxent_prefix_log_likelihood, random_policy, reward, tiny_mdp,
                               trajectories)


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


GRID = gridworld(3, 3, start=(0, 0), goal=(2, 0), slip=0.1, horizon=4)
GRID_MDP = GRID.mdp
GRID_T, GRID_X, GRID_A = GRID_MDP.horizon, GRID_MDP.n_states, GRID_MDP.n_actions
UNIFORM = np.full((GRID_T, GRID_X, GRID_A), 1.0 / GRID_A)
RATIO = np.zeros((GRID_T, GRID_X, GRID_A))
MASK = np.ones((GRID_X, GRID_A), dtype=bool)


CASES = [
    (legibility_weights, (0,), {}, ValueError, "horizon"),
    (legibility_weights, (4, "early"), {}, ValueError, "kind"),
    (legible_backup, (GRID_MDP, MASK, RATIO, 0.0, np.ones(GRID_T)), {}, ValueError, "alpha"),
    (legible_backup, (GRID_MDP, MASK, RATIO, 1.0, np.ones(GRID_T + 1)), {}, ValueError, "weights"),
    (legible_backup, (GRID_MDP, MASK, RATIO[1:], 1.0, np.ones(GRID_T)), {}, ValueError, "step_ratio: shape"),
    (legible_backup, (GRID_MDP, MASK, RATIO + np.inf, 1.0, np.ones(GRID_T)), {}, ValueError, "step_ratio: must be finite"),
    (legible_backup, (GRID_MDP, np.ones((GRID_X, GRID_A, 2), bool), RATIO, 1.0, np.ones(GRID_T)), {}, ValueError, "mask"),
    (legible_objective, (GRID_MDP, UNIFORM, RATIO, 1.0, np.ones(GRID_T - 1)), {}, ValueError, "weights"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{c[0].__name__ if hasattr(c[0], '__name__') else 'call'}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase):
        fn(*args, **kwargs)
