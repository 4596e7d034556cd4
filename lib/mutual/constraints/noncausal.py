"""Causal versus non-causal maximum entropy by brute force (Section 2.2.4), on MDPs small enough
to list every trajectory.

The non-causal distribution of eqs. (2.5)/(2.9) weights whole trajectories, P(xi) proportional
to p_0(x_0) prod_t S(x_t, a_t, x_{t+1}) exp(R(xi)) Phi_C(xi) (Ziebart's 2008 form for stochastic
dynamics; with deterministic S the dynamics factor only fixes the support). It lets the agent
pick its outcomes: under it the next state given (x_t, a_t) no longer follows S. The causal
distribution (eqs. 2.16-2.19) draws each action from P_C(a_t | x_t, t) and each next state from
S. For deterministic dynamics both coincide; :func:`causal_versus_noncausal` measures how far
apart they are on a given MDP, each number computed from the listed trajectories, not from a
backup.
"""

import itertools

import numpy as np

from .mdp import check_mask, soft_policy

MAX_TRAJECTORIES = 500_000


def enumerate_trajectories(mdp):
    """Every (states (M, T+1), actions (M, T)) from a start with p_0 > 0 (brute force)."""
    starts = np.flatnonzero(mdp.initial > 0)
    X, A, T = mdp.n_states, mdp.n_actions, mdp.horizon
    count = starts.size * (X * A) ** T
    if count > MAX_TRAJECTORIES:
        raise ValueError(f"mdp: {count} trajectories to list, more than {MAX_TRAJECTORIES}; use a smaller MDP")
    steps = np.array(list(itertools.product(range(X * A), repeat=T))).reshape(-1, T)
    states = np.empty((starts.size * steps.shape[0], T + 1), dtype=np.int64)
    states[:, 0] = np.repeat(starts, steps.shape[0])
    tiled = np.tile(steps, (starts.size, 1))
    states[:, 1:] = tiled % X
    return states, tiled // X


def _log_terms(mdp, states, actions, mask):
    """log p_0, sum log S, R(xi) and whether Phi_C allows every step, per trajectory."""
    S = mdp.dense_transitions()
    x, a, nxt = states[:, :-1], actions, states[:, 1:]
    with np.errstate(divide="ignore"):
        log_p0 = np.log(mdp.initial[states[:, 0]])
        log_S = np.log(S[x, a, nxt]).sum(axis=1)
    reward = mdp.reward[x, a].sum(axis=1) + mdp.terminal_reward[states[:, -1]]
    return log_p0, log_S, reward, check_mask(mdp, mask)[x, a].all(axis=1)


def _normalise(log_w):
    finite = np.isfinite(log_w)
    p = np.zeros_like(log_w)
    p[finite] = np.exp(log_w[finite] - log_w[finite].max())
    return p / p.sum()


def noncausal_probabilities(mdp, states, actions, mask=None):
    """P(xi) of the non-causal distribution (eqs. 2.5/2.9 with the dynamics factor)."""
    log_p0, log_S, reward, ok = _log_terms(mdp, states, actions, mask)
    return _normalise(np.where(ok, log_p0 + log_S + reward, -np.inf))


def causal_probabilities(mdp, states, actions, mask=None):
    """P(xi) = p_0(x_0) prod_t P_C(a_t | x_t, t) S(x_t, a_t, x_{t+1}) (eqs. 2.16-2.19)."""
    pi = soft_policy(mdp, mask)
    t = np.arange(mdp.horizon)
    log_p0, log_S, _, _ = _log_terms(mdp, states, actions, mask)
    with np.errstate(divide="ignore"):
        log_pi = np.log(pi[t, states[:, :-1], actions]).sum(axis=1)
    return np.exp(log_p0 + log_S + log_pi)


def transition_error(mdp, states, actions, probs):
    """max over t, x, a (with mass) of |P(x_{t+1} = x' | x_t = x, a_t = a) - S(x, a, x')| under
    the trajectory distribution ``probs``: 0 when the next state follows the dynamics."""
    X, A = mdp.n_states, mdp.n_actions
    S = mdp.dense_transitions()
    worst = 0.0
    for t in range(mdp.horizon):
        joint = np.zeros((X, A, X))
        np.add.at(joint, (states[:, t], actions[:, t], states[:, t + 1]), probs)
        mass = joint.sum(axis=2)
        seen = mass > 1e-300
        worst = max(worst, float(np.abs(joint[seen] / mass[seen][:, None] - S[seen]).max(initial=0.0)))
    return worst


def action_marginals(mdp, states, actions, probs):
    """P(a_t = a | x_t = x) at every t (T, X, A) under ``probs`` (nan where x_t has no mass)."""
    out = np.zeros((mdp.horizon, mdp.n_states, mdp.n_actions))
    for t in range(mdp.horizon):
        np.add.at(out[t], (states[:, t], actions[:, t]), probs)
    with np.errstate(invalid="ignore"):
        return out / out.sum(axis=2, keepdims=True)


def soft_value_by_enumeration(mdp, mask=None):
    """V_0 as the causal entropy-regularised return, E[sum_t (r(x_t, a_t) - log P_C(a_t | x_t, t)) +
    w(x_T)] over the listed trajectories from a point start -- equal to the soft backup's V_0(x_0)."""
    states, actions = enumerate_trajectories(mdp)
    probs = causal_probabilities(mdp, states, actions, mask)
    pi = soft_policy(mdp, mask)
    t = np.arange(mdp.horizon)
    live = probs > 0
    s, a = states[live], actions[live]
    gain = mdp.reward[s[:, :-1], a].sum(axis=1) + mdp.terminal_reward[s[:, -1]] - np.log(pi[t, s[:, :-1], a]).sum(axis=1)
    return float(probs[live] @ gain)


def causal_versus_noncausal(mdp, mask=None):
    """How the two distributions differ on ``mdp`` (brute force over every trajectory):
    ``dynamics_error`` of each (how far its next state given (x, a) is from S), ``policy_gap``
    (max |P(a_t | x_t)| difference), ``kl`` = KL(causal || non-causal) in nats and
    ``loglik_gap`` = the causal agent's expected log-likelihood under the causal model minus
    under the non-causal one (= kl), all from the listed trajectories."""
    states, actions = enumerate_trajectories(mdp)
    causal = causal_probabilities(mdp, states, actions, mask)
    noncausal = noncausal_probabilities(mdp, states, actions, mask)
    both = causal > 0
    with np.errstate(divide="ignore"):
        kl = float(causal[both] @ (np.log(causal[both]) - np.log(noncausal[both])))
    gap = np.abs(action_marginals(mdp, states, actions, causal) - action_marginals(mdp, states, actions, noncausal))
    return dict(dynamics_error_causal=transition_error(mdp, states, actions, causal),
                dynamics_error_noncausal=transition_error(mdp, states, actions, noncausal),
                policy_gap=float(np.nanmax(gap)), kl=kl, loglik_gap=kl, trajectories=int(states.shape[0]))
