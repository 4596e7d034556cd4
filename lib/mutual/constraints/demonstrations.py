"""Demonstrations (Section 2.2.2): N trajectories of states and actions, sampled from the
maximum-causal-entropy policy (eq. 2.19), their exact log-likelihood, and their CSV format.

Demonstrations CSV (``write_demonstrations`` / ``load_demonstrations``): one row per time step,
columns ``demo, t, state, action``; ``t`` runs 0..L in every demo, ``state`` is an integer index
of the MDP, ``action`` an integer index on every row but each demo's last, where it is empty.
"""

from dataclasses import dataclass

import numpy as np
import pandas as pd

from .. import budget
from ..atomic import atomic_path
from ..inputs import number_column, read_csv
from ..seeds import generator
from .mdp import MDP, check_mask, soft_policy


@dataclass(frozen=True, eq=False)
class Demonstrations:
    """N demonstrations of L steps: ``states`` (N, L+1) and ``actions`` (N, L) integer arrays."""

    states: np.ndarray
    actions: np.ndarray

    def __post_init__(self):
        s, a = np.asarray(self.states), np.asarray(self.actions)
        if s.ndim != 2 or a.ndim != 2 or s.shape[0] != a.shape[0] or s.shape[1] != a.shape[1] + 1 or a.shape[1] < 1:
            raise ValueError(f"states/actions: shapes {s.shape} and {a.shape} should be (N, L+1) and (N, L), L >= 1")
        if s.shape[0] < 1:
            raise ValueError("states/actions: need at least one demonstration")
        if not (np.issubdtype(s.dtype, np.integer) and np.issubdtype(a.dtype, np.integer)):
            raise ValueError("states/actions: must be integer arrays")
        object.__setattr__(self, "states", s.astype(np.int64))
        object.__setattr__(self, "actions", a.astype(np.int64))

    def __repr__(self):
        starts = np.unique(self.states[:, 0])
        return (f"Demonstrations(N = {self.n}, L = {self.steps} steps, "
                f"{starts.size} start state{'s' if starts.size > 1 else ''})")

    @property
    def n(self):
        return self.states.shape[0]

    @property
    def steps(self):
        return self.actions.shape[1]

    def pairs(self):
        """All demonstrated (x_t, a_t) pairs as two flat arrays."""
        return self.states[:, :-1].ravel(), self.actions.ravel()


def _first_problem(mdp, demos):
    """``(message, demo, t, column)`` of the first way ``demos`` does not fit ``mdp``, or None."""
    s, a = demos.states, demos.actions
    if s.min() < 0 or s.max() >= mdp.n_states:
        d, t = np.argwhere((s < 0) | (s >= mdp.n_states))[0]
        return f"unknown state {s[d, t]}; states are 0..{mdp.n_states - 1}", d, t, "state"
    if a.min() < 0 or a.max() >= mdp.n_actions:
        d, t = np.argwhere((a < 0) | (a >= mdp.n_actions))[0]
        return f"unknown action {a[d, t]}; actions are 0..{mdp.n_actions - 1}", d, t, "action"
    if demos.steps > mdp.horizon:
        return f"{demos.steps} steps exceed the horizon T = {mdp.horizon}", 0, mdp.horizon + 1, "t"
    offered = mdp.allowed[s[:, :-1], a]
    if not offered.all():
        d, t = np.argwhere(~offered)[0]
        return f"action {a[d, t]} is not available in state {s[d, t]} (MDP.allowed)", d, t, "action"
    rows = (s[:, :-1] * mdp.n_actions + a).ravel()
    prob = np.asarray(mdp.transitions[rows, s[:, 1:].ravel()]).ravel()
    if np.any(prob <= 0):
        d, t = divmod(int(np.flatnonzero(prob <= 0)[0]), demos.steps)
        return (f"moving from state {s[d, t]} with action {a[d, t]} to state {s[d, t + 1]} is a transition "
                "with zero probability under S"), d, t + 1, "state"
    return None


def check_demonstrations(mdp, demos):
    """Raise ValueError if ``demos`` has unknown states/actions, is longer than the
    horizon, takes an action its state does not offer, or takes a transition that has
    zero probability under S."""
    if not isinstance(mdp, MDP):
        raise TypeError(f"mdp: must be an MDP, got {type(mdp).__name__}")
    if not isinstance(demos, Demonstrations):
        raise TypeError(f"demos: must be Demonstrations, got {type(demos).__name__}")
    problem = _first_problem(mdp, demos)
    if problem:
        message, d, t, _ = problem
        raise ValueError(f"demonstrations: demo {d}, t {t}: {message}")
    return demos


def sample_demonstrations(mdp, n, mask=None, rng=None, allow_large=None):
    """Sample ``n`` trajectories of T steps from the constrained Boltzmann policy (eq. 2.19).

    Starts are drawn from ``mdp.initial``; ``rng`` is a seed or numpy Generator; ``allow_large`` as
    :func:`mutual.budget.check` (``n`` trajectories are held in memory).
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n: must be a positive integer, got {n!r}")
    if not isinstance(mdp, MDP):
        raise TypeError(f"mdp: must be an MDP, got {type(mdp).__name__}")
    budget.check(budget.demonstrations(n, mdp.horizon), allow_large)
    rng = generator(rng, "rng")
    pi = soft_policy(mdp, check_mask(mdp, mask))
    if np.any(pi[0].sum(axis=1)[mdp.initial > 0] == 0):
        raise ValueError("mask: no trajectory from some initial state satisfies the constraints (V = -inf)")
    return sample_trajectories(mdp, pi, n, rng)


def sample_trajectories(mdp, policy, n, rng):
    """``n`` trajectories of T steps of ``policy`` (T, X, A) from ``mdp.initial`` (``rng``: a Generator): the
    start, then at each step every trajectory's action and next state, each one :func:`categorical` draw."""
    T, X, A = mdp.horizon, mdp.n_states, mdp.n_actions
    states = np.empty((n, T + 1), dtype=np.int64)
    actions = np.empty((n, T), dtype=np.int64)
    states[:, 0] = categorical(np.broadcast_to(mdp.initial, (n, X)), rng)
    for t in range(T):
        actions[:, t] = categorical(policy[t, states[:, t]], rng)
        rows = mdp.transitions[states[:, t] * A + actions[:, t]]
        states[:, t + 1] = categorical(rows.toarray() if mdp.is_sparse else rows, rng)
    return Demonstrations(states, actions)


def categorical(probs, rng):
    """One draw per row of ``probs`` by inverting its cumulative sum with one uniform number per row (rows
    summing to 1; an all-zero row gives the last index)."""
    cdf = np.cumsum(probs, axis=1)
    u = rng.random(probs.shape[0]) * cdf[:, -1]
    return np.minimum((cdf <= u[:, None]).sum(axis=1), probs.shape[1] - 1)


def demonstration_log_likelihood(mdp, demos, mask=None):
    """sum_i sum_t log P_C(a_t | x_t, t) of the demonstrations (eq. 2.19); -inf if any is infeasible.

    The dynamics' factor S(x_t, a_t, x_{t+1}) does not depend on the constraints and is left out.
    """
    check_demonstrations(mdp, demos)
    pi = soft_policy(mdp, mask)
    t = np.broadcast_to(np.arange(demos.steps), demos.actions.shape)
    with np.errstate(divide="ignore"):
        return float(np.log(pi[t, demos.states[:, :-1], demos.actions]).sum())


DEMONSTRATION_COLUMNS = ("demo", "t", "state", "action")


def write_demonstrations(path, demos):
    """Write ``demos`` atomically in the CSV format of :func:`load_demonstrations`."""
    if not isinstance(demos, Demonstrations):
        raise TypeError(f"demos: must be Demonstrations, got {type(demos).__name__}")
    n, L = demos.n, demos.steps
    actions = np.concatenate([demos.actions, np.full((n, 1), -1)], axis=1).ravel()
    df = pd.DataFrame({"demo": np.repeat(np.arange(n), L + 1), "t": np.tile(np.arange(L + 1), n),
                       "state": demos.states.ravel(),
                       "action": pd.array(np.where(actions < 0, None, actions), dtype="Int64")})
    with atomic_path(path) as tmp:
        df.to_csv(tmp, index=False)
    return path


def _integers(frame, column, allow_empty=False):
    """Column ``column`` as float values (nan where empty), refusing text, fractions and integers of 2^53 or more
    (beyond exact floats and any index: never wrap around) with a ValueError naming the file, line and column."""
    return number_column(frame, column, allow_empty, whole=True, what="an integer")


def load_demonstrations(path, mdp):
    """Read demonstrations from CSV and check them against ``mdp``.

    Format: a header ``demo,t,state,action`` and one row per visited state.
    ``demo`` numbers the demonstrations 0..N-1; ``t`` runs 0..L in each (every
    demonstration has the same L <= T steps); ``state`` (0..X-1) is x_t;
    ``action`` (0..A-1) is a_t, taken in x_t, and is empty on each demonstration's
    last row (t = L, the state reached). For a :class:`mutual.constraints.gridworld.Gridworld`,
    state = col + width * row (row 0 at the bottom) and actions follow
    ``GRID_ACTIONS``. Every problem -- an empty file, a missing column, text or a fraction
    where an integer belongs, an action on a last row, an unknown state or action, an
    action the state does not offer, a transition with zero probability under S -- raises
    a ValueError naming the file, the line (1 = the header) and the column.
    """
    frame = read_csv(path, DEMONSTRATION_COLUMNS)       # names the file and line of every malformed row
    values = {c: _integers(frame, c, allow_empty=(c == "action")) for c in DEMONSTRATION_COLUMNS}
    line = np.asarray(frame.attrs["lines"])
    order = np.lexsort((values["t"], values["demo"]))
    demo, t, state, action, line = (a[order] for a in (values["demo"], values["t"], values["state"],
                                                        values["action"], line))
    ids, counts = np.unique(demo, return_counts=True)
    if not np.array_equal(ids, np.arange(ids.size)):
        odd = ids[int(np.flatnonzero(ids != np.arange(ids.size))[0])]
        raise ValueError(f"{path}, line {int(line[demo == odd][0])}, column 'demo': demo ids must run 0..N-1 "
                         f"without gaps; found {int(odd)}")
    if len(set(counts)) != 1 or counts[0] < 2:
        d = int(np.flatnonzero(counts != counts[0])[0]) if len(set(counts)) != 1 else 0
        raise ValueError(f"{path}, line {int(line[demo == d][0])}, column 'demo': every demo must have the same "
                         f"number (>= 2) of rows; demo {d} has {int(counts[d])}, demo 0 has {int(counts[0])}")
    n, L = ids.size, int(counts[0]) - 1
    shape = (n, L + 1)
    t, state, action, line = t.reshape(shape), state.reshape(shape), action.reshape(shape), line.reshape(shape)
    wrong = t != np.arange(L + 1)
    if wrong.any():
        d, k = np.argwhere(wrong)[0]
        raise ValueError(f"{path}, line {line[d, k]}, column 't': t must run 0..{L} without gaps in every demo")
    if np.isnan(action[:, :-1]).any():
        d, k = np.argwhere(np.isnan(action[:, :-1]))[0]
        raise ValueError(f"{path}, line {line[d, k]}, column 'action': empty; an action is needed on every row "
                         "but each demo's last")
    if not np.isnan(action[:, -1]).all():
        d = int(np.flatnonzero(~np.isnan(action[:, -1]))[0])
        raise ValueError(f"{path}, line {line[d, -1]}, column 'action': {int(action[d, -1])} on the last row of "
                         f"demo {d} (t = {L}); the state reached takes no action, leave it empty")
    demos = Demonstrations(state.astype(np.int64), action[:, :-1].astype(np.int64))
    problem = _first_problem(mdp, demos)
    if problem:
        message, d, k, column = problem
        raise ValueError(f"{path}, line {line[d, min(k, L)]}, column {column!r}: {message}")
    return demos
