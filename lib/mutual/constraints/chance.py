"""Chance constraints on states and their maximum-likelihood risk thresholds
(Sections 3.1-3.2).

A chance constraint on state x_bar with threshold psi allows action a in state
x only if S(x, a, x_bar) <= psi (eq. 3.1); psi = 0 forbids x_bar outright and
psi = 1 is vacuous. Bundled with forbidden actions this gives the allowed-action
mask Phi_C(a, x) of eq. (3.2), the input of every backup in :mod:`mutual.constraints.mdp`.
"""

import numpy as np

from .demonstrations import check_demonstrations


def _nonzeros(mdp):
    """(row, col, value) of the non-zero entries of S as a (X*A, X) matrix."""
    P = mdp.transitions
    if mdp.is_sparse:
        coo = P.tocoo()
        return coo.row, coo.col, coo.data
    r, c = np.nonzero(P)
    return r, c, P[r, c]


def chance_forbidden(mdp, states, psi):
    """For K state chance constraints (x_bar_k, psi_k): the (X, A, K) boolean array
    of actions they forbid, [S(x, a, x_bar_k) > psi_k] (eq. 3.1)."""
    states = np.atleast_1d(np.asarray(states))
    psi = np.asarray(psi, dtype=float)
    if psi.ndim > 1 or psi.size not in (1, states.size):
        raise ValueError(f"psi: needs one threshold or one per state ({states.size}), got shape {psi.shape}")
    psi = np.broadcast_to(psi.ravel(), states.shape)
    if states.ndim != 1 or (states.size and (not np.issubdtype(states.dtype, np.integer)
                                             or states.min() < 0 or states.max() >= mdp.n_states)):
        raise ValueError(f"states: must be a 1-D array of state indices in 0..{mdp.n_states - 1}")
    if np.any(np.isnan(psi)) or np.any(psi < 0) or np.any(psi > 1):
        raise ValueError("psi: risk thresholds must lie in [0, 1]")
    forbidden = np.zeros((mdp.n_states * mdp.n_actions, states.size), dtype=bool)
    row, col, val = _nonzeros(mdp)
    # join each non-zero S(x, a, x') with every constraint k on x' (a state may carry several)
    order = np.argsort(states, kind="stable")
    lo = np.searchsorted(states[order], col, side="left")
    count = np.searchsorted(states[order], col, side="right") - lo
    entry = np.repeat(np.arange(col.size), count)
    k = order[np.repeat(lo, count) + np.arange(entry.size) - np.repeat(np.cumsum(count) - count, count)]
    hit = val[entry] > psi[k]
    forbidden[row[entry[hit]], k[hit]] = True
    return forbidden.reshape(mdp.n_states, mdp.n_actions, states.size)


def constraint_mask(mdp, states=(), psi=0.0, actions=()):
    """The allowed-action mask Phi_C (X, A) of eq. (3.2): state chance constraints
    (``states`` with thresholds ``psi``) together with forbidden ``actions``."""
    actions = np.asarray(actions, dtype=int)
    if actions.size and (actions.min() < 0 or actions.max() >= mdp.n_actions):
        raise ValueError(f"actions: indices must lie in 0..{mdp.n_actions - 1}")
    mask = ~chance_forbidden(mdp, np.asarray(states, dtype=int), psi).any(axis=2)
    mask[:, actions] = False
    return mask


def max_likelihood_thresholds(mdp, demos):
    """psi*(x) = max over demonstrated (x_t, a_t) of S(x_t, a_t, x), eq. (3.3) (Lemma 3.2.1).

    The lowest threshold on x that keeps every demonstration feasible; 0 for
    states no demonstrated action could reach.
    """
    check_demonstrations(mdp, demos)
    x, a = demos.pairs()
    rows = np.unique(x * mdp.n_actions + a)
    block = mdp.transitions[rows]
    return np.asarray(block.max(axis=0).toarray() if mdp.is_sparse else block.max(axis=0)).ravel()
