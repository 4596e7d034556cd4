"""Demonstrations (Section 2.2.2): N trajectories of states and actions, sampled from the
maximum-causal-entropy policy (eq. 2.19), their exact log-likelihood, and their CSV format.

Demonstrations CSV (``write_demonstrations`` / ``load_demonstrations``): one row per time step,
columns ``demo, t, state, action``; ``t`` runs 0..L in every demo, ``state`` is an integer index
of the MDP, ``action`` an integer index on every row but each demo's last, where it is empty.
"""

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..atomic import atomic_path
from .mdp import soft_policy


@dataclass(frozen=True, eq=False)
class Demonstrations:
    """N demonstrations of L steps: ``states`` (N, L+1) and ``actions`` (N, L) integer arrays."""

    states: np.ndarray
    actions: np.ndarray

    def __post_init__(self):
        s, a = np.asarray(self.states), np.asarray(self.actions)
        if s.ndim != 2 or a.ndim != 2 or s.shape[0] != a.shape[0] or s.shape[1] != a.shape[1] + 1 or a.shape[1] < 1:
            raise ValueError(f"states/actions: shapes {s.shape} and {a.shape} should be (N, L+1) and (N, L), L >= 1")
        if not (np.issubdtype(s.dtype, np.integer) and np.issubdtype(a.dtype, np.integer)):
            raise ValueError("states/actions: must be integer arrays")
        object.__setattr__(self, "states", s.astype(np.int64))
        object.__setattr__(self, "actions", a.astype(np.int64))

    @property
    def n(self):
        return self.states.shape[0]

    @property
    def steps(self):
        return self.actions.shape[1]

    def pairs(self):
        """All demonstrated (x_t, a_t) pairs as two flat arrays."""
        return self.states[:, :-1].ravel(), self.actions.ravel()


def check_demonstrations(mdp, demos):
    """Raise ValueError if ``demos`` has unknown states/actions, is longer than the
    horizon, or takes a transition that has zero probability under S."""
    s, a = demos.states, demos.actions
    if s.min() < 0 or s.max() >= mdp.n_states:
        bad = np.argwhere((s < 0) | (s >= mdp.n_states))[0]
        raise ValueError(f"demonstrations: unknown state {s[tuple(bad)]} (demo {bad[0]}, t {bad[1]}); "
                         f"states are 0..{mdp.n_states - 1}")
    if a.min() < 0 or a.max() >= mdp.n_actions:
        bad = np.argwhere((a < 0) | (a >= mdp.n_actions))[0]
        raise ValueError(f"demonstrations: unknown action {a[tuple(bad)]} (demo {bad[0]}, t {bad[1]}); "
                         f"actions are 0..{mdp.n_actions - 1}")
    if demos.steps > mdp.horizon:
        raise ValueError(f"demonstrations: {demos.steps} steps exceed the horizon T = {mdp.horizon}")
    rows = (s[:, :-1] * mdp.n_actions + a).ravel()
    prob = np.asarray(mdp.transitions[rows, s[:, 1:].ravel()]).ravel()
    if np.any(prob <= 0):
        i = int(np.flatnonzero(prob <= 0)[0])
        d, t = divmod(i, demos.steps)
        raise ValueError(f"demonstrations: demo {d} moves from state {s[d, t]} with action {a[d, t]} to state "
                         f"{s[d, t + 1]} at t {t}, a transition with zero probability under S")
    return demos


def sample_demonstrations(mdp, n, mask=None, rng=None):
    """Sample ``n`` trajectories of T steps from the constrained Boltzmann policy (eq. 2.19).

    Starts are drawn from ``mdp.initial``; ``rng`` is a seed or numpy Generator.
    """
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n: must be a positive integer, got {n!r}")
    rng = np.random.default_rng(rng)
    pi = soft_policy(mdp, mask)
    if np.any(pi[0].sum(axis=1)[mdp.initial > 0] == 0):
        raise ValueError("mask: some initial state has no allowed action")
    T, X, A = mdp.horizon, mdp.n_states, mdp.n_actions
    states = np.empty((n, T + 1), dtype=np.int64)
    actions = np.empty((n, T), dtype=np.int64)
    states[:, 0] = _draw(np.broadcast_to(mdp.initial, (n, X)), rng)
    for t in range(T):
        actions[:, t] = _draw(pi[t, states[:, t]], rng)
        rows = mdp.transitions[states[:, t] * A + actions[:, t]]
        states[:, t + 1] = _draw(rows.toarray() if mdp.is_sparse else rows, rng)
    return Demonstrations(states, actions)


def _draw(probs, rng):
    """One categorical draw per row of ``probs`` (rows sum to 1)."""
    cdf = np.cumsum(probs, axis=1)
    u = rng.random(probs.shape[0]) * cdf[:, -1]
    return np.minimum((cdf <= u[:, None]).sum(axis=1), probs.shape[1] - 1)


def demonstration_log_likelihood(mdp, demos, mask=None):
    """sum_i sum_t log P_C(a_t | x_t, t) of the demonstrations (eq. 2.19); -inf if any is infeasible.

    The dynamics' factor S(x_t, a_t, x_{t+1}) does not depend on the constraints and is left out.
    """
    pi = soft_policy(mdp, mask)
    t = np.broadcast_to(np.arange(demos.steps), demos.actions.shape)
    with np.errstate(divide="ignore"):
        return float(np.log(pi[t, demos.states[:, :-1], demos.actions]).sum())


DEMONSTRATION_COLUMNS = ("demo", "t", "state", "action")


def write_demonstrations(path, demos):
    """Write ``demos`` atomically in the CSV format of :func:`load_demonstrations`."""
    n, L = demos.n, demos.steps
    actions = np.concatenate([demos.actions, np.full((n, 1), -1)], axis=1).ravel()
    df = pd.DataFrame({"demo": np.repeat(np.arange(n), L + 1), "t": np.tile(np.arange(L + 1), n),
                       "state": demos.states.ravel(),
                       "action": pd.array(np.where(actions < 0, None, actions), dtype="Int64")})
    with atomic_path(path) as tmp:
        df.to_csv(tmp, index=False)
    return path


def load_demonstrations(path, mdp):
    """Read demonstrations from CSV and check them against ``mdp``.

    Format: a header ``demo,t,state,action`` and one row per visited state.
    ``demo`` numbers the demonstrations 0..N-1; ``t`` runs 0..L in each (every
    demonstration has the same L <= T steps); ``state`` (0..X-1) is x_t;
    ``action`` (0..A-1) is a_t, taken in x_t, and is empty on each demonstration's
    last row (t = L, the state reached). For a :class:`mutual.constraints.mdp.Gridworld`,
    state = col + width * row (row 0 at the bottom) and actions follow
    ``GRID_ACTIONS``. Unknown states or actions, and transitions with zero
    probability under S, raise a ValueError naming the row.
    """
    df = pd.read_csv(path)
    missing = [c for c in DEMONSTRATION_COLUMNS if c not in df.columns]
    if missing:
        raise ValueError(f"{path}: missing columns {missing}; expected {list(DEMONSTRATION_COLUMNS)}")
    for col in ("demo", "t", "state"):
        if df[col].isna().any() or not np.all(np.mod(df[col], 1) == 0):
            raise ValueError(f"{path}: column {col!r} must hold integers on every row")
    df = df.sort_values(["demo", "t"], kind="stable")
    demo_ids = np.unique(df["demo"])
    if not np.array_equal(demo_ids, np.arange(len(demo_ids))):
        raise ValueError(f"{path}: demo ids must be 0..N-1")
    lengths = df.groupby("demo").size().to_numpy()
    if len(set(lengths)) != 1 or lengths[0] < 2:
        raise ValueError(f"{path}: every demo must have the same number (>= 2) of rows")
    n, L = len(demo_ids), int(lengths[0]) - 1
    t = df["t"].to_numpy(dtype=np.int64).reshape(n, L + 1)
    if not np.all(t == np.arange(L + 1)):
        raise ValueError(f"{path}: t must run 0..{L} without gaps in every demo")
    action = df["action"].to_numpy(dtype=float).reshape(n, L + 1)
    if np.isnan(action[:, :-1]).any() or np.any(np.mod(action[:, :-1], 1) != 0):
        raise ValueError(f"{path}: action must be an integer on every row but each demo's last")
    states = df["state"].to_numpy(dtype=np.int64).reshape(n, L + 1)
    return check_demonstrations(mdp, Demonstrations(states, action[:, :-1].astype(np.int64)))
