"""The human observer of the discrete loop: a likelihood-ratio test (Sec. 6.3) between two
maximum-causal-entropy models of the robot (eq. 2.19), on the states and actions seen so far.

H1, "the robot respects my constraints": P_C1(a | x, t) with the observer's constraints C1.
H0, "the robot ignores them": P_C0(a | x, t) with no constraints (or a baseline C0).

Under both hypotheses a trajectory's probability is p_0(x_0) prod_t P_H(a_t | x_t, t) S(x_t, a_t,
x_{t+1}); the dynamics cancel in the ratio, so after t steps the observer's log-likelihood ratio
in favour of H1 is exactly

    log Lambda_{0:t} = sum_{s < t} l_s(x_s, a_s),   l_s(x, a) = log P_C1(a | x, s) - log P_C0(a | x, s),

(the reciprocal of eq. 6.7's Lambda) and the posterior log-odds are logit(prior) + log Lambda_{0:t}.
An action that C1 forbids gives l = -inf: the observer then knows for certain that H1 is false.
"""

import numpy as np
from scipy.special import expit, logit

from ..constraints import check_mask, soft_policy
from .outcomes import check_policy


def step_log_ratio(mdp, mask_h1, mask_h0=None):
    """l_t(x, a) = log P_C1(a | x, t) - log P_C0(a | x, t) (T, X, A) for the constrained Boltzmann
    policies of eq. (2.19): -inf where C1 forbids an action that C0 allows, nan where both do."""
    mask_h1 = check_mask(mdp, mask_h1, "mask_h1")
    mask_h0 = check_mask(mdp, mask_h0, "mask_h0")
    if mask_h1.ndim != 2 or mask_h0.ndim != 2:
        raise ValueError("mask_h1/mask_h0: must be (X, A) masks")
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log(soft_policy(mdp, mask_h1)) - np.log(soft_policy(mdp, mask_h0))


def _check_prior(prior):
    if not (isinstance(prior, (int, float, np.floating)) and 0 < prior < 1):
        raise ValueError(f"prior: P(H1) before any observation must lie in (0, 1), got {prior!r}")
    return float(prior)


def log_odds_paths(step_ratio, rollouts, prior=0.5):
    """The observer's log-odds log P(H1 | x_0, a_0, ..., x_t) / P(H0 | ...) after each step:
    (N, L+1) for ``rollouts`` (Demonstrations of L <= T steps); column 0 is logit(prior)."""
    prior = _check_prior(prior)
    ratio = np.asarray(step_ratio, dtype=float)
    x, a = rollouts.states[:, :-1], rollouts.actions
    if ratio.ndim != 3 or ratio.shape[0] < rollouts.steps or x.max() >= ratio.shape[1] or a.max() >= ratio.shape[2]:
        raise ValueError(f"step_ratio: shape {ratio.shape} does not fit rollouts of {rollouts.steps} steps")
    steps = ratio[np.arange(rollouts.steps)[None, :], x, a]
    if np.isnan(steps).any():
        raise ValueError("rollouts: take an action that both hypotheses forbid (probability 0 under both)")
    with np.errstate(invalid="ignore"):
        path = logit(prior) + np.concatenate([np.zeros((rollouts.n, 1)), np.cumsum(steps, axis=1)], axis=1)
    # once -inf (H1 refuted), cumsum keeps -inf; +inf (H0 refuted) likewise
    return path


def posterior_paths(step_ratio, rollouts, prior=0.5):
    """P(H1 | trajectory so far) after each step, (N, L+1)."""
    return expit(log_odds_paths(step_ratio, rollouts, prior))


def time_to_confidence(posterior, level=0.95):
    """The first step t at which P(H1 | x_0..x_t) >= ``level`` for each row of ``posterior``
    (N, L+1); ``np.nan`` where it never does within the horizon."""
    if not 0.5 <= level < 1:
        raise ValueError(f"level: a confidence in [0.5, 1), got {level!r}")
    post = np.asarray(posterior, dtype=float)
    reached = post >= level
    first = reached.argmax(axis=1).astype(float)
    first[~reached.any(axis=1)] = np.nan
    return first


def expected_log_odds(mdp, policy, step_ratio, prior=0.5):
    """E[log-odds after t steps] for t = 0..T, exactly by a forward pass, with the mass that took an
    H1-forbidden action reported separately. Returns ``(mean (T+1,), p_refuted (T+1,))``: the
    mean log-odds over the trajectories that have not yet refuted H1, and the probability that H1
    has been refuted (log-odds -inf) by step t."""
    prior = _check_prior(prior)
    pi = check_policy(mdp, policy)
    ratio = np.asarray(step_ratio, dtype=float)
    if ratio.shape != pi.shape:
        raise ValueError(f"step_ratio: shape {ratio.shape} should match the policy's {pi.shape}")
    if np.any(np.isposinf(ratio) & (pi > 0)) or np.any(np.isnan(ratio) & (pi > 0)):
        raise ValueError("step_ratio: the policy takes an action that H0 forbids (+inf) or both forbid (nan); "
                         "H0's support must contain H1's")
    finite = np.isfinite(ratio)
    alive = mdp.initial.astype(float)       # mass that has not refuted H1
    accrued = np.zeros(mdp.n_states)        # sum over that mass of its log-ratio so far
    mean, refuted = [logit(prior)], [0.0]
    P_T = mdp.transitions.T
    for t in range(mdp.horizon):
        w = alive[:, None] * pi[t] * finite[t]
        acc = (accrued[:, None] * pi[t] + w * np.where(finite[t], ratio[t], 0.0)) * finite[t]
        alive = np.asarray(P_T @ w.ravel()).ravel()
        accrued = np.asarray(P_T @ acc.ravel()).ravel()
        total = alive.sum()
        refuted.append(max(0.0, 1.0 - total))
        mean.append(logit(prior) + (accrued.sum() / total if total > 0 else np.nan))
    return np.array(mean), np.array(refuted)
