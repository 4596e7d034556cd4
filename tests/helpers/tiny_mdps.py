"""Tiny MDPs small enough to enumerate every trajectory and every deterministic policy: the brute-force truth
of the cycle's discrete tests."""

import itertools

import numpy as np

from mutual.constraints.mdp import MDP


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
