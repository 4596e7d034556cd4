"""The part of an MDP that the demonstrations' likelihood can see: the states reachable from their starts.

Algorithm 4 computes V_{C,t}(x) at every state, but the ranking (eq. 2.25) reads V_{C,0} at the
demonstrations' starts only, and their likelihood (eq. 2.19) reads Q_{C,t} and V_{C,t} at the
demonstrated x_t only. Let R_0 be the starts and R_{t+1} the states that some offered action of
some x in R_t reaches with positive probability. V_{C,t} on R_t depends on V_{C,t+1} on R_{t+1}
alone, for every constraint set C (constraints only remove actions), and every demonstrated x_t
lies in R_t. So the backup restricted to U = R_0 u ... u R_T gives the same numbers -- exactly, the
same operations on the same values -- and the boolean backup of :mod:`.feasibility` the same -inf
pattern. On a discretized continuous system whose demonstrations start in a small region the
restriction halves the work (the cart-pole of ``data/examples/cartpole.toml``: 52% of the cells).

:func:`restricted` builds the sub-MDP on U, its states numbered by the step at which they are
first reached (then V_{C,t} is needed on a prefix only: :func:`.gather.segments`), with the rows that
leave U -- of states first reached at T, never backed up from, or of actions not offered -- made
self-loops so that it is a valid MDP,
maps the demonstrations and masks onto it, and caches the result per MDP and set of starts.
"""

import weakref
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .demonstrations import Demonstrations
from .mdp import MDP

#: restrict only when U holds at most this share of the states (else the copy costs more than it saves)
WORTH = 0.9

_CACHE = weakref.WeakKeyDictionary()


@dataclass(frozen=True, eq=False)
class Restriction:
    """The sub-MDP ``mdp`` on the reachable ``states`` (their numbers in the full MDP, in the sub-MDP's
    order), ``layers`` (T+1,): how many of them are reached within 0, 1, ..., T steps, and ``rows``: the
    full MDP's state-action rows x*A + a of those states, in the sub-MDP's order."""

    mdp: MDP
    states: np.ndarray
    layers: np.ndarray
    rows: np.ndarray

    def demos(self, demos):
        """``demos`` with their states renumbered onto the sub-MDP."""
        renumber = np.full(max(int(self.states.max()), int(demos.states.max())) + 1, -1, dtype=np.int64)
        renumber[self.states] = np.arange(self.states.size)
        return Demonstrations(renumber[demos.states], demos.actions)

    def mask(self, mask):
        """An (X, A) or (X, A, K) mask of the full MDP restricted to the sub-MDP's states."""
        return np.asarray(mask)[self.states]

    def columns(self, forbidden):
        """Candidate columns -- sparse (X*A, K) or dense (X, A, K) -- restricted to the sub-MDP."""
        return sp.csr_matrix(forbidden)[self.rows] if sp.issparse(forbidden) else np.asarray(forbidden)[self.states]


def first_reached(mdp, starts):
    """The step (0..T) at which each state is first reached from ``starts`` by offered actions, -1 for
    states not reached within the horizon (module docstring)."""
    A = mdp.n_actions
    support = sp.csr_matrix(mdp.transitions, copy=True)
    support.data = (support.data > 0).astype(np.float32)
    support = sp.csr_matrix(support.multiply(mdp.allowed.reshape(-1, 1))).T.tocsr()     # (X, X*A)
    step = np.full(mdp.n_states, -1, dtype=np.int64)
    front = np.zeros(mdp.n_states, dtype=bool)
    front[np.asarray(starts)] = True
    for t in range(mdp.horizon + 1):
        new = front & (step < 0)
        if not new.any():
            break
        step[new] = t
        front = np.asarray(support @ np.repeat(new, A).astype(np.float32)).ravel() > 0
    return step


def restricted(mdp, starts):
    """The :class:`Restriction` of ``mdp`` to the states reachable from ``starts``, or None when they
    are more than ``WORTH`` of all states. Cached per MDP and set of starts."""
    starts = np.unique(np.asarray(starts, dtype=np.int64))
    key = starts.tobytes()
    cache = _CACHE.setdefault(mdp, {})
    if key not in cache:
        step = first_reached(mdp, starts)
        cache[key] = _build(mdp, step) if (step >= 0).sum() <= WORTH * mdp.n_states else None
    return cache[key]


def _build(mdp, step):
    X, A = mdp.n_states, mdp.n_actions
    reached = np.flatnonzero(step >= 0)
    states = reached[np.argsort(step[reached], kind="stable")]          # by first step, then by number
    layers = np.searchsorted(step[states], np.arange(mdp.horizon + 1), side="right")
    rows = (states[:, None] * A + np.arange(A)).ravel()
    renumber = np.full(X, -1, dtype=np.int64)
    renumber[states] = np.arange(states.size)
    coo = sp.csr_matrix(mdp.transitions)[rows].tocoo()
    loops = np.unique(coo.row[renumber[coo.col] < 0])     # first reached at T, or not offered: self-loops
    keep = ~np.isin(coo.row, loops)
    S = sp.csr_matrix((np.r_[coo.data[keep], np.ones(loops.size)],
                       (np.r_[coo.row[keep], loops], np.r_[renumber[coo.col[keep]], loops // A])),
                      shape=(states.size * A, states.size))
    sub = MDP(S, mdp.reward[states], mdp.horizon, terminal_reward=mdp.terminal_reward[states],
              allowed=mdp.allowed[states])
    return Restriction(sub, states, layers, rows)
