"""Chance constraints on states and their maximum-likelihood risk thresholds
(Sections 3.1-3.2).

A chance constraint on state x_bar with threshold psi allows action a in state
x only if S(x, a, x_bar) <= psi (eq. 3.1); psi = 0 forbids x_bar outright and
psi = 1 is vacuous. Bundled with forbidden actions this gives the allowed-action
mask Phi_C(a, x) of eq. (3.2), the input of every backup in :mod:`mutual.constraints.mdp`.
"""

import numpy as np
import scipy.sparse as sp

from .demonstrations import check_demonstrations


def _nonzeros(mdp):
    """(row, col, value) of the non-zero entries of S as a (X*A, X) matrix."""
    P = mdp.transitions
    if mdp.is_sparse:
        coo = P.tocoo()
        return coo.row, coo.col, coo.data
    r, c = np.nonzero(P)
    return r, c, P[r, c]


def index_array(values, name, size):
    """``values`` as a 1-D int64 array of indices in 0..size-1, refusing non-integers (2.7),
    booleans and out-of-range entries with a ValueError naming ``name``."""
    arr = np.atleast_1d(np.asarray(values))
    if arr.size == 0:
        return np.empty(0, dtype=np.int64)
    if arr.ndim != 1 or arr.dtype == bool or not (np.issubdtype(arr.dtype, np.integer) or (
            np.issubdtype(arr.dtype, np.floating) and np.all(np.isfinite(arr)) and np.all(arr == np.round(arr)))):
        raise ValueError(f"{name}: must be a 1-D list of integer indices, got {values!r}")
    arr = arr.astype(np.int64)
    if arr.min() < 0 or arr.max() >= size:
        raise ValueError(f"{name}: indices must lie in 0..{size - 1}, got {int(arr.min())}..{int(arr.max())}")
    return arr


def _thresholds(psi, n):
    if isinstance(psi, (bool, np.bool_)) or (isinstance(psi, (str, bytes))):
        raise ValueError(f"psi: risk thresholds must be numbers in [0, 1], got {psi!r}")
    try:
        psi = np.asarray(psi, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"psi: risk thresholds must be numbers in [0, 1], got {psi!r}") from None
    if psi.ndim > 1 or psi.size not in (1, n):
        raise ValueError(f"psi: needs one threshold or one per state ({n}), got shape {psi.shape}")
    if np.any(np.isnan(psi)) or np.any(psi < 0) or np.any(psi > 1):
        raise ValueError("psi: risk thresholds must lie in [0, 1]")
    return np.broadcast_to(psi.ravel(), (n,))


def chance_forbidden(mdp, states, psi, sparse=False):
    """For K state chance constraints (x_bar_k, psi_k): the actions they forbid,
    [S(x, a, x_bar_k) > psi_k] (eq. 3.1), as an (X, A, K) boolean array or, with
    ``sparse``, a boolean CSC matrix of shape (X*A, K)."""
    states = index_array(states, "states", mdp.n_states)
    psi = _thresholds(psi, states.size)
    row, col, val = _nonzeros(mdp)
    # join each non-zero S(x, a, x') with every constraint k on x' (a state may carry several)
    order = np.argsort(states, kind="stable")
    lo = np.searchsorted(states[order], col, side="left")
    count = np.searchsorted(states[order], col, side="right") - lo
    entry = np.repeat(np.arange(col.size), count)
    k = order[np.repeat(lo, count) + np.arange(entry.size) - np.repeat(np.cumsum(count) - count, count)]
    hit = val[entry] > psi[k]
    shape = (mdp.n_states * mdp.n_actions, states.size)
    if sparse:
        return sp.csc_matrix((np.ones(int(hit.sum()), dtype=bool), (row[entry[hit]], k[hit])), shape=shape)
    forbidden = np.zeros(shape, dtype=bool)
    forbidden[row[entry[hit]], k[hit]] = True
    return forbidden.reshape(mdp.n_states, mdp.n_actions, states.size)


def constraint_mask(mdp, states=(), psi=0.0, actions=()):
    """The allowed-action mask Phi_C (X, A) of eq. (3.2): state chance constraints
    (``states`` with thresholds ``psi``, one or one per state) together with forbidden
    ``actions``. Indices must be integers (2.7 is refused, not truncated)."""
    actions = index_array(actions, "actions", mdp.n_actions)
    mask = ~chance_forbidden(mdp, states, psi).any(axis=2)
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


def psi_star_by_loop(S, states, actions):
    """Eq. (3.3) written out as the thesis states it, for checking: for every state x,
    max over demonstrations xi and steps t of S(x_t, a_t, x), by plain Python loops over a
    dense S (X, A, X) and the demonstrations' ``states`` (N, L+1) and ``actions`` (N, L)."""
    S = np.asarray(S, dtype=float)
    psi = [0.0] * S.shape[0]
    for xs, acts in zip(np.asarray(states).tolist(), np.asarray(actions).tolist()):
        for t, a in enumerate(acts):
            for x in range(S.shape[0]):
                psi[x] = max(psi[x], float(S[xs[t], a, x]))
    return np.array(psi)


def threshold_levels(mdp, state):
    """The thresholds at which a chance constraint on ``state`` changes what it allows: 0, every distinct
    transition chance into the state, and 1 (inactive)."""
    S = mdp.dense_transitions()[:, :, index_array(state, "state", mdp.n_states)[0]]
    return np.unique(np.concatenate([[0.0, 1.0], S[S > 0]]))


def lemma_321_exact(mdp, demos, states=None, base_mask=None):
    """Lemma 3.2.1 on the exact likelihood: for each state, the demonstrations' log-likelihood (eq. 2.19,
    :func:`~mutual.constraints.demonstrations.demonstration_log_likelihood`, one soft backup per threshold)
    at every threshold a constraint on it can take (:func:`threshold_levels`).

    Returns a DataFrame, one row per state with psi* < 1 (eq. 3.3): ``psi*``, ``lowest feasible`` (the
    lowest threshold that keeps every demonstration possible -- above psi* when psi* leaves some state on a
    demonstration's path without an allowed action), ``gain at lowest`` (nats per demonstration over the
    unconstrained C0, psi = 1), the threshold with the largest likelihood (``best psi``, ``best gain``) and
    ``holds``: the likelihood is largest at the lowest feasible threshold, to 1e-12 nats (the lemma)."""
    import pandas as pd

    from .demonstrations import demonstration_log_likelihood

    base = np.ones((mdp.n_states, mdp.n_actions), dtype=bool) if base_mask is None else np.asarray(base_mask)
    psi_star = max_likelihood_thresholds(mdp, demos)
    states = np.arange(mdp.n_states) if states is None else index_array(states, "states", mdp.n_states)
    ll0 = demonstration_log_likelihood(mdp, demos, base)
    rows = []
    for x in states:
        if psi_star[x] >= 1:
            continue
        levels = threshold_levels(mdp, x)
        levels = levels[levels >= psi_star[x] - 1e-15]
        gains = np.array([(demonstration_log_likelihood(mdp, demos, base & constraint_mask(mdp, [x], psi)) - ll0)
                          / demos.n for psi in levels])
        feasible = np.flatnonzero(np.isfinite(gains))
        lowest, best = feasible[0], feasible[np.argmax(gains[feasible])]
        rows.append({"state": int(x), "psi*": float(psi_star[x]), "lowest feasible": float(levels[lowest]),
                     "gain at lowest": float(gains[lowest]), "best psi": float(levels[best]),
                     "best gain": float(gains[best]), "holds": bool(gains[lowest] >= gains[best] - 1e-12)})
    return pd.DataFrame(rows)
