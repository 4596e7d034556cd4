"""What a robot's policy does in a tabular MDP, computed exactly by forward passes (no sampling):
the probability that it ever breaks a constraint, ever enters a forbidden state, and its expected
task reward (eq. 2.3) -- and, for comparison and for the observer, sampled rollouts.

A policy is an array ``P(a | x, t)`` of shape (T, X, A), e.g. the constrained Boltzmann policy of
eq. (2.19) from :func:`mutual.constraints.mdp.soft_policy`. The forward pass is Algorithm 1's
(lines 17-30) with the memory of Algorithm 2: mass that has broken a constraint once stays broken.
"""

import numpy as np

from ..constraints import check_mask, sample_trajectories


_ROUNDING = 1e-12  # a probability below this is the sums' rounding (e.g. 1 - 0.9999999999999999) and reported as 0


def check_policy(mdp, policy, name="policy"):
    """Validate a policy (T, X, A): finite, non-negative, rows summing to 1 (or 0 for dead states)."""
    pi = np.asarray(policy, dtype=float)
    if pi.shape != (mdp.horizon, mdp.n_states, mdp.n_actions):
        raise ValueError(f"{name}: shape {pi.shape} should be (T, X, A) = "
                         f"{(mdp.horizon, mdp.n_states, mdp.n_actions)}")
    if not np.all(np.isfinite(pi)) or np.any(pi < 0):
        raise ValueError(f"{name}: must be finite and non-negative")
    sums = pi.sum(axis=2)
    if not np.all(np.isclose(sums, 1.0, atol=1e-9) | (sums == 0)):
        raise ValueError(f"{name}: every row P(. | x, t) must sum to 1 (or be all zero for a dead state)")
    return pi


def _step(mdp, mass, pi_t):
    """Mass (X,) times the policy (X, A) pushed through S: the next state distribution (X,)."""
    return np.asarray(mdp.transitions.T @ (mass[:, None] * pi_t).ravel()).ravel()


def policy_outcomes(mdp, policy, allowed=None, forbidden_states=()):
    """Exact outcomes of running ``policy`` from ``mdp.initial`` for T steps.

    ``allowed``: the allowed-action mask Phi_C (X, A) of a constraint set (eq. 3.2; e.g. the
    human's true constraints): an action outside it *breaks* the constraints.
    ``forbidden_states``: states whose *entry* counts separately (e.g. the true constrained
    cells; with chance constraints an allowed action may still slip into one).
    Returns a dict: ``p_break`` (probability of ever taking an action outside ``allowed``),
    ``p_enter`` (of ever being in a forbidden state, x_0 included), ``p_either``,
    ``expected_reward`` (E[sum_t r(x_t, a_t) + w(x_T)], eq. 2.3), ``p_final`` (X,) the
    distribution of x_T, and ``occupancy`` (T, X) the state distribution at each t. Probabilities below
    1e-12 are the rounding of sums of probabilities and reported as 0.
    """
    pi = check_policy(mdp, policy)
    allowed = check_mask(mdp, allowed, "allowed")
    if allowed.ndim != 2:
        raise ValueError("allowed: must be one (X, A) mask")
    avoid = np.zeros(mdp.n_states, dtype=bool)
    states = np.asarray(forbidden_states, dtype=int).ravel()
    if states.size and (states.min() < 0 or states.max() >= mdp.n_states):
        raise ValueError(f"forbidden_states: state indices must lie in 0..{mdp.n_states - 1}")
    avoid[states] = True
    mass = mdp.initial.astype(float)
    clean_break = mass.copy()                    # never broke a constraint so far
    clean_enter = np.where(avoid, 0.0, mass)     # never entered a forbidden state so far
    clean_both = clean_enter.copy()
    reward = 0.0
    occupancy = np.empty((mdp.horizon, mdp.n_states))
    for t in range(mdp.horizon):
        occupancy[t] = mass
        reward += float(np.sum(mass[:, None] * pi[t] * mdp.reward))
        keep = pi[t] * allowed
        clean_break = _step(mdp, clean_break, keep)
        clean_both = np.where(avoid, 0.0, _step(mdp, clean_both, keep))
        clean_enter = np.where(avoid, 0.0, _step(mdp, clean_enter, pi[t]))
        mass = _step(mdp, mass, pi[t])
    reward += float(mass @ mdp.terminal_reward)
    lost = [1.0 - float(c.sum()) for c in (clean_break, clean_enter, clean_both)]
    lost = [v if v > _ROUNDING else 0.0 for v in lost]
    return {"p_break": lost[0], "p_enter": lost[1], "p_either": lost[2], "expected_reward": reward, "p_final": mass,
            "occupancy": occupancy}


def sample_rollouts(mdp, policy, n, rng=None):
    """``n`` trajectories of T steps of ``policy`` (T, X, A) from ``mdp.initial``, as
    :class:`mutual.constraints.Demonstrations` (``rng``: seed or Generator).

    Rows of a dead state (all-zero policy) fall back to the last action; use policies that keep every
    reachable state alive (e.g. the soft policy of a feasible constraint set).
    """
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n: must be a positive integer, got {n!r}")
    return sample_trajectories(mdp, check_policy(mdp, policy), n, np.random.default_rng(rng))


def rollout_outcomes(mdp, rollouts, allowed=None, forbidden_states=()):
    """The same outcomes as :func:`policy_outcomes`, counted on sampled ``rollouts`` (the Monte
    Carlo check of the forward pass): fractions breaking, entering, either, and the mean reward."""
    allowed = check_mask(mdp, allowed, "allowed")
    x, a = rollouts.states, rollouts.actions
    avoid = np.zeros(mdp.n_states, dtype=bool)
    avoid[np.asarray(forbidden_states, dtype=int).ravel()] = True
    broke = (~allowed[x[:, :-1], a]).any(axis=1)
    entered = avoid[x].any(axis=1)
    reward = mdp.reward[x[:, :-1], a].sum(axis=1) + mdp.terminal_reward[x[:, -1]]
    return {"p_break": float(broke.mean()), "p_enter": float(entered.mean()),
            "p_either": float((broke | entered).mean()), "expected_reward": float(reward.mean())}
