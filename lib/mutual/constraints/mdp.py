"""Tabular finite-horizon Markov decision processes (Section 2.2.1) and their
soft, maximum-causal-entropy Bellman backup (eqs. 2.16-2.21), in log space.

An :class:`MDP` holds the transition tensor S(x, a, x') -- dense ``(X, A, X)``
or a ``scipy.sparse`` matrix of shape ``(X*A, X)`` whose row ``x*A + a`` is
S(x, a, .) -- the running reward r(x, a), the terminal reward w(x), the horizon
T, the initial state distribution and which actions each state offers. A
trajectory collects r(x_t, a_t) for t = 0..T-1 and w(x_T) (eq. 2.3), so
V_0(x) = log Z(x) (eq. 2.24).

Constraints enter as an allowed-action mask Phi_C(x, a) (eq. 2.12 or 3.2):
boolean ``(X, A)``, or ``(X, A, K)`` for K constraint sets backed up at once.

**Actions a state does not offer** (e.g. the gridworld's loiter action, offered
at the goal only, Section 3.3) are the structural mask ``MDP.allowed`` (X, A):
every backup, policy, sampler and candidate ANDs it into Phi_C (:func:`check_mask`),
so an unavailable action is forbidden under every constraint set, gets Q = -inf and
probability 0, and no demonstration may take it. Its row S(x, a, .) must still be a
probability distribution (it is never used). Every state must offer an action.

Forbidden actions get Q = -inf; a state with no allowed action gets V = -inf,
and -inf values never turn into NaN (0 * -inf is avoided explicitly).
"""

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

_ATOL = 1e-9
MAX_VALUE = 1e100  # |r| T + |w| must stay below this: values far inside the float64 range


@dataclass(frozen=True, eq=False)
class MDP:
    """A validated finite-horizon MDP (Section 2.2.1).

    ``transitions``: S(x, a, x') as a dense ``(X, A, X)`` array or an ``(X*A, X)``
    matrix (dense or sparse; row ``x*A + a``); ``reward``: r(x, a) as ``(X, A)`` (or ``(X,)``, the same
    for every action); ``terminal_reward``: w(x) as ``(X,)`` (default 0);
    ``horizon``: T >= 1; ``initial``: p_0 as ``(X,)`` (default uniform);
    ``allowed``: the actions each state offers, boolean ``(X, A)`` (default all).
    Rewards are refused when T max|r| + max|w| exceeds ``MAX_VALUE`` (1e100).
    """

    transitions: object
    reward: np.ndarray
    horizon: int
    terminal_reward: np.ndarray = None
    initial: np.ndarray = None
    allowed: np.ndarray = None

    def __post_init__(self):
        P, n_states, n_actions = _check_transitions(self.transitions)
        reward = _float_array(self.reward, "reward")
        if reward.shape == (n_states,):
            reward = np.repeat(reward[:, None], n_actions, axis=1)
        if reward.shape != (n_states, n_actions):
            raise ValueError(f"reward: shape {reward.shape} should be (X, A) = {(n_states, n_actions)} or (X,)")
        if not np.all(np.isfinite(reward)):
            raise ValueError("reward: must be finite everywhere")
        w = np.zeros(n_states) if self.terminal_reward is None else _float_array(self.terminal_reward,
                                                                                  "terminal_reward")
        if w.shape != (n_states,):
            raise ValueError(f"terminal_reward: shape {w.shape} should be (X,) = ({n_states},)")
        if not np.all(np.isfinite(w)):
            raise ValueError("terminal_reward: must be finite everywhere")
        if isinstance(self.horizon, bool) or not isinstance(self.horizon, (int, np.integer)) or self.horizon < 1:
            raise ValueError(f"horizon: must be an integer >= 1, got {self.horizon!r}")
        bound = int(self.horizon) * float(np.abs(reward).max()) + float(np.abs(w).max())
        if bound > MAX_VALUE:
            raise ValueError(f"reward: T max|r| + max|w| = {bound:.3g} exceeds {MAX_VALUE:.0e}; rescale the "
                             "rewards (soft values this large lose every digit of the policy)")
        p0 = np.full(n_states, 1.0 / n_states) if self.initial is None else _float_array(self.initial, "initial")
        if p0.shape != (n_states,):
            raise ValueError(f"initial: shape {p0.shape} should be (X,) = ({n_states},)")
        if not np.all(np.isfinite(p0)) or np.any(p0 < 0) or not np.isclose(p0.sum(), 1.0, atol=_ATOL):
            raise ValueError("initial: must be a probability distribution (non-negative, summing to 1)")
        allowed = np.ones((n_states, n_actions), dtype=bool) if self.allowed is None else np.asarray(self.allowed)
        if allowed.dtype != bool or allowed.shape != (n_states, n_actions):
            raise ValueError(f"allowed: must be a boolean array of shape (X, A) = {(n_states, n_actions)}, "
                             f"got dtype {allowed.dtype} and shape {allowed.shape}")
        if not allowed.any(axis=1).all():
            raise ValueError(f"allowed: state {int(np.flatnonzero(~allowed.any(axis=1))[0])} offers no action")
        allowed = allowed.copy()
        allowed.setflags(write=False)
        for name, value in (("transitions", P), ("reward", reward), ("terminal_reward", w),
                            ("horizon", int(self.horizon)), ("initial", p0), ("allowed", allowed)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "n_states", n_states)
        object.__setattr__(self, "n_actions", n_actions)

    def __repr__(self):
        kind = f"sparse S, nnz {self.transitions.nnz}" if self.is_sparse else "dense S"
        off = int((~self.allowed).sum())
        return (f"MDP(|X| = {self.n_states}, |A| = {self.n_actions}, T = {self.horizon}, {kind}"
                + (f", {off} state-action pairs unavailable" if off else "") + ")")

    @property
    def is_sparse(self):
        return sp.issparse(self.transitions)

    def dense_transitions(self):
        """S(x, a, x') as a dense ``(X, A, X)`` array."""
        P = self.transitions.toarray() if self.is_sparse else self.transitions
        return P.reshape(self.n_states, self.n_actions, self.n_states)


def _float_array(value, name):
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: must be an array of numbers, got {type(value).__name__}") from None


def _tolerance(S, n_states):
    """How far a row of S may sum from 1: ``_ATOL``, or the rounding of S's own dtype (a float32 S
    given with rows that sum to 1 in float32 is stochastic; it is renormalised in float64)."""
    dtype = S.dtype if hasattr(S, "dtype") else np.asarray(S).dtype
    if np.issubdtype(dtype, np.floating) and np.finfo(dtype).eps > np.finfo(float).eps:
        return max(_ATOL, (n_states + 1) * float(np.finfo(dtype).eps))
    return _ATOL


def _check_transitions(S):
    """Return S as a ``(X*A, X)`` float array or CSR matrix, checking it is stochastic."""
    original = S
    if sp.issparse(S):
        if S.ndim != 2 or S.shape[1] == 0 or S.shape[0] == 0 or S.shape[0] % S.shape[1]:
            raise ValueError(f"transitions: a sparse S must have shape (X*A, X), got {S.shape}")
        P = sp.csr_matrix(S, dtype=float)
        P.sum_duplicates()
        values, row_sums = P.data, np.asarray(P.sum(axis=1)).ravel()
        n_states = S.shape[1]
    else:
        S = _float_array(S, "transitions")
        if S.ndim == 2 and S.shape[1] and S.shape[0] and S.shape[0] % S.shape[1] == 0:
            S = S.reshape(S.shape[1], -1, S.shape[1])          # the (X*A, X) layout of MDP.transitions
        if S.ndim != 3 or S.shape[0] != S.shape[2] or S.shape[0] == 0 or S.shape[1] == 0:
            raise ValueError(f"transitions: a dense S must have shape (X, A, X) or (X*A, X), got {S.shape}")
        n_states = S.shape[0]
        P = np.ascontiguousarray(S.reshape(-1, n_states))
        values, row_sums = P, P.sum(axis=1)
    if not np.all(np.isfinite(values)) or np.any(values < 0):
        raise ValueError("transitions: S must be finite and non-negative")
    tolerance = _tolerance(original, n_states)
    bad = np.flatnonzero(np.abs(row_sums - 1.0) > tolerance)
    if bad.size:
        x, a = divmod(int(bad[0]), P.shape[0] // n_states)
        raise ValueError(f"transitions: S(x, a, .) must sum to 1; S({x}, {a}, .) sums to {row_sums[bad[0]]:.6g}")
    if tolerance > _ATOL:     # a lower-precision S: make its rows sum to 1 in float64
        P = sp.diags(1.0 / row_sums) @ P if sp.issparse(P) else P / row_sums[:, None]
        P = sp.csr_matrix(P) if sp.issparse(P) else P
    return P, n_states, P.shape[0] // n_states


# ---------------------------------------------------------------- soft backup

def expected_next(mdp, values):
    """E_{x' ~ S(x, a, .)} V(x') for ``values`` of shape (X,) or (X, K) -> (X, A[, K]).

    Terms with S = 0 contribute nothing even where V = -inf; any positive
    chance of reaching a V = -inf state makes the expectation -inf.
    """
    V = np.asarray(values, dtype=float)
    dead = np.isneginf(V)
    if dead.any():
        EV = _times_transitions(mdp, np.where(dead, 0.0, V))
        EV[_times_transitions(mdp, dead.astype(float)) > 0] = -np.inf
    else:
        EV = _times_transitions(mdp, V)
    return EV.reshape((mdp.n_states, mdp.n_actions) + V.shape[1:])


def _times_transitions(mdp, V):
    """S as a (X*A, X) matrix times V; scipy's sparse product runs column by column,
    which is about twice as fast on a column-major V."""
    if mdp.is_sparse:
        return np.asarray(mdp.transitions @ np.asfortranarray(V))
    return mdp.transitions @ V


def _transpose_times(mdp, W):
    """S^T (an (X, X*A) matrix) times W: the forward pass of Algorithms 1-2 (state-action mass
    to next-state mass)."""
    return np.asarray(mdp.transitions.T @ W)


def masked_logsumexp(Q, forbidden, axis=1):
    """log sum_a exp(Q) over the allowed entries; overwrites ``Q`` (eq. 2.21).

    ``forbidden`` is the complement of Phi_C (broadcastable to Q). All-forbidden
    slices give -inf without warnings.
    """
    if forbidden is not None:
        np.copyto(Q, -np.inf, where=forbidden)
    m = Q.max(axis=axis, keepdims=True)
    m[~np.isfinite(m)] = 0.0
    np.subtract(Q, m, out=Q)
    np.exp(Q, out=Q)
    with np.errstate(divide="ignore"):
        return np.log(Q.sum(axis=axis)) + np.squeeze(m, axis=axis)


def check_mask(mdp, mask, name="mask"):
    """Validate an allowed-action mask Phi_C -- boolean (X, A) or (X, A, K); None means no
    constraint -- and AND it with the actions each state offers (``mdp.allowed``)."""
    if mask is None:
        return mdp.allowed.copy()
    mask = np.asarray(mask)
    if mask.dtype != bool:
        raise ValueError(f"{name}: must be a boolean array, got dtype {mask.dtype}")
    if mask.ndim not in (2, 3) or mask.shape[:2] != (mdp.n_states, mdp.n_actions):
        raise ValueError(f"{name}: shape {mask.shape} should be (X, A) or (X, A, K) with (X, A) = "
                         f"{(mdp.n_states, mdp.n_actions)}")
    return mask & (mdp.allowed if mask.ndim == 2 else mdp.allowed[:, :, None])


def soft_bellman_backup(mdp, mask=None):
    """The constrained soft Bellman backup, eqs. (2.19)-(2.21), for one constraint set.

    Returns ``(V, Q)`` with V of shape (T+1, X) (V[T] = w, V[0] = log Z) and
    Q of shape (T, X, A) (Q = -inf for forbidden and unavailable actions).
    """
    mask = check_mask(mdp, mask)
    if mask.ndim != 2:
        raise ValueError("mask: soft_bellman_backup takes one (X, A) mask; use log_partition for a batch")
    T, forbidden = mdp.horizon, ~mask
    V = np.empty((T + 1, mdp.n_states))
    Q = np.empty((T, mdp.n_states, mdp.n_actions))
    V[T] = mdp.terminal_reward
    for t in range(T - 1, -1, -1):
        Q[t] = mdp.reward + expected_next(mdp, V[t + 1])
        Q[t][forbidden] = -np.inf
        V[t] = masked_logsumexp(Q[t].copy(), None)
    return V, Q


def soft_policy(mdp, mask=None):
    """The constrained Boltzmann policy P_C(a | x, t) = Phi_C exp(Q - V), eq. (2.19): (T, X, A).

    Computed as a softmax relative to each row's largest Q, so every row of a state
    with an allowed action sums to 1 up to rounding (1e-12) for any rewards the
    :class:`MDP` accepts; a state with no allowed action (V = -inf) gets an all-zero row.
    """
    _, Q = soft_bellman_backup(mdp, mask)
    top = Q.max(axis=2, keepdims=True)
    alive = np.isfinite(top)
    with np.errstate(invalid="ignore"):
        pi = np.exp(np.where(alive, Q - np.where(alive, top, 0.0), -np.inf))
    total = pi.sum(axis=2, keepdims=True)
    return np.divide(pi, total, out=np.zeros_like(pi), where=total > 0)
