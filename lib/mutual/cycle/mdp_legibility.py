"""Legible behaviour in an MDP: the counterpart of chapter 6's objective (eqs. 6.13-6.16) for the
observer of :mod:`mutual.cycle.observer`, solved by the soft Bellman backup of Chapter 2.

Chapter 6 lets the robot minimise (1 + alpha) H_J1 - H_J0, i.e. maximise the observer's log-likelihood
ratio of H1 over H0 plus alpha times the task's own log-likelihood. In an MDP the observer's log ratio
after the whole trajectory is sum_t l_t(x_t, a_t) with l_t = log P_C1 - log P_C0 (see
:mod:`mutual.cycle.observer`), a sum of per-step rewards, so the objective

    J(pi) = E_pi[ sum_t w_t l_t(x_t, a_t) ] + alpha E_pi[ R(xi) ]                      (1)

(w_t = 1: the final log ratio; the E_pi[log P_C1(xi)] of eq. 6.15 differs from E_pi[R] by a
constant, telescoping eq. 2.19) is an MDP with reward w_t l_t + alpha r and terminal reward alpha w.
Backward induction (hard) gives the legible robot of chapter 6; with the robot's own entropy added,
alpha (E[R] + H(pi)), dividing by alpha gives the soft backup of eqs. 2.19-2.21 with the reward
r + (w_t / alpha) l_t, whose policy is a maximum-causal-entropy robot like the demonstrator.

**The final ratio cannot be improved.** With H1 = constraints C1 and H0 = C0 on the same reward,
eq. 2.19 gives l_t(x, a) = E_{x'} Delta_{t+1}(x') - Delta_t(x) for every action C1 allows, where
Delta_t = V_C1,t - V_C0,t = log F_t (Theorem 2.3.1). The sum telescopes: for *every* policy that
respects C1, E[sum_t l_t] = -Delta_0(x_0) = -log F_C1,0(x_0), a constant (Delta_T = 0). So with
w_t = 1 the legible policy is the plain one (soft: P_C1 itself; hard: the reward-optimal robot
within C1), for every alpha -- the MDP face of chapter 7's remark that hypotheses with different
supports are hard to "subtract". The *anticipatory* weights w_t = (T - t) / T (the mean over t of
the observer's log-odds, the counterpart of Sec. 6.5's early evidence) do change behaviour: the
same telescoping turns them into the reward (1 / T) Delta_t(x_t) on the states visited, so the
legible robot heads for states from which even an unconstrained agent would comply.
"""

import numpy as np

from ..constraints import check_mask, expected_next, masked_logsumexp
from .outcomes import check_policy

WEIGHTS = ("final", "anticipatory")


def legibility_weights(horizon, kind="anticipatory"):
    """w_t of eq. (1) for t = 0..T-1: ones for the final log ratio ("final"), (T - t) / T for the
    mean over time of the observer's log-odds ("anticipatory": sum_{t=1}^T log Lambda_{0:t} / T)."""
    if not isinstance(horizon, (int, np.integer)) or horizon < 1:
        raise ValueError(f"horizon: must be an integer >= 1, got {horizon!r}")
    if kind not in WEIGHTS:
        raise ValueError(f"kind: must be one of {WEIGHTS}, got {kind!r}")
    t = np.arange(horizon)
    return np.ones(horizon) if kind == "final" else (horizon - t) / horizon


def _check(mdp, mask, step_ratio, alpha, weights):
    mask = check_mask(mdp, mask)
    if mask.ndim != 2:
        raise ValueError("mask: must be one (X, A) mask (the robot's constraints)")
    ratio = np.asarray(step_ratio, dtype=float)
    if ratio.shape != (mdp.horizon, mdp.n_states, mdp.n_actions):
        raise ValueError(f"step_ratio: shape {ratio.shape} should be (T, X, A)")
    if np.any(np.isnan(ratio[:, mask])) or np.any(np.isposinf(ratio[:, mask])):
        raise ValueError("step_ratio: must be finite or -inf on the actions the mask allows")
    if not (np.isfinite(alpha) and alpha > 0):
        raise ValueError(f"alpha: the weight on the task must be positive and finite, got {alpha!r}")
    w = np.asarray(weights, dtype=float)
    if w.shape != (mdp.horizon,) or not np.all(np.isfinite(w)):
        raise ValueError(f"weights: need T = {mdp.horizon} finite weights, got shape {w.shape}")
    return mask, ratio, float(alpha), w


def legible_backup(mdp, mask, step_ratio, alpha, weights, soft=True):
    """Solve eq. (1) by backward induction within the robot's constraints ``mask``.

    ``step_ratio``: the observer's l_t (T, X, A) as the robot models it (:func:`mutual.cycle.observer.
    step_log_ratio`); ``alpha`` > 0 the task weight; ``weights`` w_t (T,). ``soft=True`` maximises
    J + alpha H(pi) by the soft backup U_t = log sum_a Phi exp(r + w_t l_t / alpha + E U_{t+1})
    (eq. 2.21 with a time-varying reward; U_T = w); ``soft=False`` maximises J by the hard backup
    U_t = max_a [w_t l_t + alpha r + E U_{t+1}] (U_T = alpha w), ties to the lowest action index.
    Returns ``(U (T+1, X), policy (T, X, A))``; the optimum of J (+ alpha H) from x is
    ``alpha * U[0, x]`` (soft) or ``U[0, x]`` (hard).
    """
    mask, ratio, alpha, w = _check(mdp, mask, step_ratio, alpha, weights)
    T, X, A = mdp.horizon, mdp.n_states, mdp.n_actions
    forbidden = ~mask
    U = np.empty((T + 1, X))
    policy = np.zeros((T, X, A))
    U[T] = mdp.terminal_reward if soft else alpha * mdp.terminal_reward
    for t in range(T - 1, -1, -1):
        with np.errstate(invalid="ignore"):
            gain = np.where(forbidden | np.isneginf(ratio[t]), -np.inf, w[t] * ratio[t])
        if soft:
            Q = mdp.reward + gain / alpha + expected_next(mdp, U[t + 1])
            Q[forbidden] = -np.inf
            U[t] = masked_logsumexp(Q.copy(), None)
            with np.errstate(invalid="ignore"):
                policy[t] = np.nan_to_num(np.exp(Q - U[t][:, None]), nan=0.0)
        else:
            Q = gain + alpha * mdp.reward + expected_next(mdp, U[t + 1])
            Q[forbidden] = -np.inf
            U[t] = Q.max(axis=1)
            best = Q.argmax(axis=1)
            live = np.isfinite(U[t])
            policy[t, np.flatnonzero(live), best[live]] = 1.0
    return U, policy


def legible_objective(mdp, policy, step_ratio, alpha, weights):
    """Eq. (1) of a given ``policy`` from ``mdp.initial``, exactly by a forward pass: returns
    ``{"legibility": E sum_t w_t l_t, "reward": E R, "entropy": E sum_t -log pi(a_t | x_t, t),
    "objective": legibility + alpha reward}`` (-inf legibility if the policy may take an action
    with l = -inf)."""
    pi = check_policy(mdp, policy)
    ratio = np.asarray(step_ratio, dtype=float)
    w = np.asarray(weights, dtype=float)
    if ratio.shape != pi.shape or w.shape != (mdp.horizon,):
        raise ValueError("step_ratio/weights: must have shapes (T, X, A) and (T,)")
    mass = mdp.initial.astype(float)
    legibility = reward = entropy = 0.0
    for t in range(mdp.horizon):
        joint = mass[:, None] * pi[t]
        taken = joint > 0
        if np.any(np.isneginf(ratio[t][taken])):
            legibility = -np.inf
        elif np.isfinite(legibility):
            legibility += w[t] * float(np.sum(joint[taken] * ratio[t][taken]))
        reward += float(np.sum(joint * mdp.reward))
        entropy -= float(np.sum(joint[taken] * np.log(pi[t][taken])))
        mass = np.asarray(mdp.transitions.T @ joint.ravel()).ravel()
    reward += float(mass @ mdp.terminal_reward)
    return {"legibility": legibility, "reward": reward, "entropy": entropy,
            "objective": legibility + float(alpha) * reward}
