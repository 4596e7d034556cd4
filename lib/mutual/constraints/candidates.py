"""The single-constraint hypotheses C+ of Section 2.4.1: one chance constraint per state at its
maximum-likelihood threshold psi* (eq. 3.3, Lemma 3.2.1) and one per action, with which of them
keep every demonstration feasible. Demonstrations of several tasks on the same dynamics may be
pooled (a list of MDPs and a list of demonstration sets)."""

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .chance import chance_forbidden, max_likelihood_thresholds
from .demonstrations import Demonstrations, check_demonstrations
from .mdp import MDP


@dataclass(frozen=True, eq=False)
class Candidates:
    """Single-constraint hypotheses C+ (Section 2.4.1).

    ``kind[k]`` is "state" or "action", ``index[k]`` the state or action, ``psi[k]``
    the state's chance threshold (nan for actions), ``forbidden_matrix`` the actions each
    forbids as a boolean sparse (X*A, K) matrix (a dense (X, A, K) array is accepted and
    converted), ``feasible[k]`` whether it keeps every demonstration possible, ``shape``
    (X, A) (taken from a dense array). :attr:`forbidden` gives the dense (X, A, K) view.
    """

    kind: np.ndarray
    index: np.ndarray
    psi: np.ndarray
    forbidden_matrix: object
    feasible: np.ndarray
    shape: tuple = None

    def __post_init__(self):
        F = self.forbidden_matrix
        if not sp.issparse(F):
            F = np.asarray(F, dtype=bool)
            if F.ndim != 3:
                raise ValueError(f"forbidden_matrix: must be sparse (X*A, K) or dense (X, A, K), got shape {F.shape}")
            object.__setattr__(self, "shape", F.shape[:2])
            F = F.reshape(-1, F.shape[2])
        elif self.shape is None or int(np.prod(self.shape)) != F.shape[0]:
            raise ValueError(f"shape: a sparse forbidden_matrix of {F.shape[0]} rows needs shape = (X, A)")
        object.__setattr__(self, "forbidden_matrix", sp.csc_matrix(F, dtype=bool))
        K = self.forbidden_matrix.shape[1]
        for name in ("kind", "index", "psi", "feasible"):
            if np.asarray(getattr(self, name)).shape != (K,):
                raise ValueError(f"{name}: needs one entry per candidate ({K})")

    def __len__(self):
        return self.kind.size

    def __repr__(self):
        states, actions = int((self.kind == "state").sum()), int((self.kind == "action").sum())
        return (f"Candidates({states} state and {actions} action constraints, {int(self.feasible.sum())} "
                f"keep every demonstration feasible)")

    @property
    def forbidden(self):
        """The actions each candidate forbids, dense boolean (X, A, K) (X*A*K bytes)."""
        X, A = self.shape
        return self.forbidden_matrix.toarray().reshape(X, A, -1)

    def label(self, k):
        return f"{self.kind[k]} {self.index[k]}"

    def find(self, kind, index):
        """The candidate number of the ``kind`` ("state"/"action") constraint on ``index``."""
        hit = np.flatnonzero((self.kind == kind) & (self.index == index))
        if hit.size != 1:
            raise ValueError(f"kind/index: no single {kind} candidate on {index}")
        return int(hit[0])


def as_tasks(mdp, demos):
    """``[(mdp, demos), ...]`` from one MDP and its demonstrations or from equally long lists of
    both (pooled tasks), checking every demonstration set against its MDP and that the pooled
    MDPs share their states, actions and dynamics S (a constraint means the same in each)."""
    pooled = isinstance(mdp, (list, tuple))
    mdps, sets = (list(mdp), list(demos)) if pooled else ([mdp], [demos])
    if pooled and (not isinstance(demos, (list, tuple)) or len(mdps) != len(sets) or not mdps):
        raise ValueError("mdp/demos: pooled tasks need equally long, non-empty lists of MDPs and demonstrations")
    for m, d in zip(mdps, sets):
        if not isinstance(m, MDP):
            raise TypeError(f"mdp: must be an MDP (or a list of them), got {type(m).__name__}")
        if not isinstance(d, Demonstrations):
            raise TypeError(f"demos: must be Demonstrations (or a list of them), got {type(d).__name__}")
        check_demonstrations(m, d)
    first = mdps[0]
    for m in mdps[1:]:
        same = (m.n_states, m.n_actions) == (first.n_states, first.n_actions) and (
            (sp.csr_matrix(m.transitions) != sp.csr_matrix(first.transitions)).nnz == 0)
        if not same:
            raise ValueError("mdp: pooled tasks must share their states, actions and transition probabilities S")
    return list(zip(mdps, sets))


def constraint_candidates(mdp, demos, states=True, actions=True, chance=True):
    """One candidate per state (a chance constraint, eq. 3.1) and per action (forbidden everywhere).

    With ``chance`` each state's threshold is the maximum-likelihood psi*(x) of
    eq. (3.3) (Lemma 3.2.1); otherwise psi = 0, the hard state constraints of
    Chapter 2. A candidate is infeasible -- never chosen -- if it forbids a
    demonstrated action in its state (a demonstrated transition exceeds its
    threshold), forbids a demonstrated action, or (psi = 0) forbids a demonstrated state.
    ``mdp`` and ``demos`` may be lists (pooled tasks on the same dynamics): psi* is then
    the maximum over all of them.
    """
    for name, flag in (("states", states), ("actions", actions), ("chance", chance)):
        if not isinstance(flag, (bool, np.bool_)):
            raise TypeError(f"{name}: must be True or False, got {flag!r}")
    tasks = as_tasks(mdp, demos)
    first = tasks[0][0]
    X, A = first.n_states, first.n_actions
    state_ids = np.arange(X) if states else np.empty(0, dtype=int)
    action_ids = np.arange(A) if actions else np.empty(0, dtype=int)
    psi_all = np.max([max_likelihood_thresholds(m, d) for m, d in tasks], axis=0)
    psi = psi_all[state_ids] if chance else np.zeros(state_ids.size)
    on_states = chance_forbidden(first, state_ids, psi, sparse=True)
    rows = (np.arange(X)[:, None] * A + action_ids[None, :]).ravel()
    on_actions = sp.csc_matrix((np.ones(rows.size, dtype=bool), (rows, np.tile(np.arange(action_ids.size), X))),
                               shape=(X * A, action_ids.size))
    forbidden = sp.hstack([on_states, on_actions], format="csc")
    pairs = np.concatenate([d.pairs()[0] * A + d.pairs()[1] for _, d in tasks])
    feasible = np.asarray(forbidden[np.unique(pairs)].sum(axis=0)).ravel() == 0
    visited = np.zeros(X, dtype=bool)
    for _, d in tasks:
        visited[d.states.ravel()] = True
    feasible[: state_ids.size] &= ~((psi == 0) & visited[state_ids])
    kind = np.array(["state"] * state_ids.size + ["action"] * action_ids.size)
    return Candidates(kind, np.concatenate([state_ids, action_ids]),
                      np.concatenate([psi, np.full(action_ids.size, np.nan)]), forbidden, feasible, (X, A))
