"""Eqs. (2.22)-(2.23) by enumeration: the causal distribution over feedback-controller sequences.

Eq. (2.23) writes the probability that the causal (maximum causal entropy) agent follows the
feedback-controller sequence a_[t:T] from x_t as e^{E[R(X, a)]} / e^{V_{C,t}(x_t)}. Under the causal
model (eq. 2.19) the agent picks its action afresh at every state it reaches, so a Markov
feedback controller pi -- an action for each (t, x) that pi itself can reach -- has probability
prod_{(t, x) reached} P_C(pi_t(x) | x). :func:`controller_check` lists every such controller of a
tiny MDP and compares the two, and sums eq. (2.23) over all controllers (a distribution sums to 1).
With deterministic dynamics each controller is one action sequence and both agree; with
stochastic dynamics they need not.
"""

import itertools

import numpy as np

from .mdp import check_mask, soft_bellman_backup

MAX_CONTROLLERS = 200_000


def _layers(S, allowed, x0, horizon):
    """Every controller as a list (over t) of {state: action} on the states it reaches, with its reach."""
    controllers = [([], {x0: 1.0})]
    for _ in range(horizon):
        grown = []
        for plan, dist in controllers:
            states = sorted(dist)
            for choice in itertools.product(*[np.flatnonzero(allowed[x]).tolist() for x in states]):
                step = dict(zip(states, choice))
                nxt = {}
                for x, p in dist.items():
                    for y in np.flatnonzero(S[x, step[x]] > 0):
                        nxt[int(y)] = nxt.get(int(y), 0.0) + p * S[x, step[x], y]
                grown.append((plan + [step], nxt))
            if len(grown) > MAX_CONTROLLERS:
                raise ValueError(f"mdp: more than {MAX_CONTROLLERS} feedback controllers; use a smaller MDP")
        controllers = grown
    return controllers


def controller_check(mdp, mask=None, start=None):
    """Every Markov feedback controller from ``start`` (default the most likely initial state) of a tiny
    ``mdp``: ``max_gap`` = max |P_causal(pi) - exp(E_pi[R] - V_0)| (eq. 2.23 against eq. 2.19),
    ``eq223_total`` = the sum of exp(E_pi[R] - V_0) over all controllers (1 if eq. 2.23 is a
    distribution), ``causal_total`` (the causal probabilities' sum, 1) and ``controllers``."""
    mask = check_mask(mdp, mask)
    S = mdp.dense_transitions()
    V, Q = soft_bellman_backup(mdp, mask)
    x0 = int(np.argmax(mdp.initial)) if start is None else int(start)
    log_pi = Q - V[:-1, :, None]
    gaps, eq223, causal = [], [], []
    for plan, final in _layers(S, mask, x0, mdp.horizon):
        log_p, expected, dist = 0.0, 0.0, {x0: 1.0}
        for t, step in enumerate(plan):
            nxt = {}
            for x, p in dist.items():
                a = step[x]
                log_p += log_pi[t, x, a]
                expected += p * mdp.reward[x, a]
                for y in np.flatnonzero(S[x, a] > 0):
                    nxt[int(y)] = nxt.get(int(y), 0.0) + p * S[x, a, y]
            dist = nxt
        expected += sum(p * mdp.terminal_reward[x] for x, p in final.items())
        causal.append(np.exp(log_p))
        eq223.append(np.exp(expected - V[0, x0]))
        gaps.append(abs(causal[-1] - eq223[-1]))
    return dict(max_gap=float(max(gaps)), eq223_total=float(sum(eq223)), causal_total=float(sum(causal)),
                controllers=len(gaps))


def random_mdp(n_states=3, n_actions=2, horizon=3, deterministic=False, seed=0):
    """A small random MDP (rewards in [-1, 0], terminal rewards in [-1, 0], start at state 0): transitions
    with full support, or each (x, a) to one random successor when ``deterministic``."""
    from .mdp import MDP

    rng = np.random.default_rng(seed)
    if deterministic:
        S = np.zeros((n_states, n_actions, n_states))
        S[np.arange(n_states)[:, None], np.arange(n_actions)[None], rng.integers(0, n_states, (n_states, n_actions))] = 1
    else:
        S = rng.dirichlet(np.ones(n_states), (n_states, n_actions))
    p0 = np.zeros(n_states)
    p0[0] = 1.0
    return MDP(S, -rng.random((n_states, n_actions)), horizon, terminal_reward=-rng.random(n_states), initial=p0)
