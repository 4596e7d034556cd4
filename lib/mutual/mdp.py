"""Tabular finite-horizon Markov decision processes (Section 2.2.1) and their
soft, maximum-causal-entropy Bellman backup (eqs. 2.16-2.21), in log space.

An :class:`MDP` holds the transition tensor S(x, a, x') -- dense ``(X, A, X)``
or a ``scipy.sparse`` matrix of shape ``(X*A, X)`` whose row ``x*A + a`` is
S(x, a, .) -- the running reward r(x, a), the terminal reward w(x), the horizon
T and the initial state distribution. A trajectory collects r(x_t, a_t) for
t = 0..T-1 and w(x_T) (eq. 2.3), so V_0(x) = log Z(x) (eq. 2.24).

Constraints enter as an allowed-action mask Phi_C(x, a) (eq. 2.12 or 3.2):
boolean ``(X, A)``, or ``(X, A, K)`` for K constraint sets backed up at once.
Forbidden actions get Q = -inf; a state with no allowed action gets V = -inf,
and -inf values never turn into NaN (0 * -inf is avoided explicitly).
"""

from dataclasses import dataclass

import numpy as np
import pandas as pd
import scipy.sparse as sp

from .atomic import atomic_path

_ATOL = 1e-9


@dataclass(frozen=True, eq=False)
class MDP:
    """A validated finite-horizon MDP (Section 2.2.1).

    ``transitions``: S(x, a, x') as a dense ``(X, A, X)`` array or a sparse
    ``(X*A, X)`` matrix; ``reward``: r(x, a) as ``(X, A)`` (or ``(X,)``, the same
    for every action); ``terminal_reward``: w(x) as ``(X,)`` (default 0);
    ``horizon``: T >= 1; ``initial``: p_0 as ``(X,)`` (default uniform).
    """

    transitions: object
    reward: np.ndarray
    horizon: int
    terminal_reward: np.ndarray = None
    initial: np.ndarray = None

    def __post_init__(self):
        P, n_states, n_actions = _check_transitions(self.transitions)
        reward = np.asarray(self.reward, dtype=float)
        if reward.shape == (n_states,):
            reward = np.repeat(reward[:, None], n_actions, axis=1)
        if reward.shape != (n_states, n_actions):
            raise ValueError(f"reward: shape {reward.shape} should be (X, A) = {(n_states, n_actions)} or (X,)")
        if not np.all(np.isfinite(reward)):
            raise ValueError("reward: must be finite everywhere")
        w = np.zeros(n_states) if self.terminal_reward is None else np.asarray(self.terminal_reward, dtype=float)
        if w.shape != (n_states,):
            raise ValueError(f"terminal_reward: shape {w.shape} should be (X,) = ({n_states},)")
        if not np.all(np.isfinite(w)):
            raise ValueError("terminal_reward: must be finite everywhere")
        if isinstance(self.horizon, bool) or not isinstance(self.horizon, (int, np.integer)) or self.horizon < 1:
            raise ValueError(f"horizon: must be an integer >= 1, got {self.horizon!r}")
        p0 = np.full(n_states, 1.0 / n_states) if self.initial is None else np.asarray(self.initial, dtype=float)
        if p0.shape != (n_states,):
            raise ValueError(f"initial: shape {p0.shape} should be (X,) = ({n_states},)")
        if np.any(p0 < 0) or not np.isclose(p0.sum(), 1.0, atol=_ATOL):
            raise ValueError("initial: must be a probability distribution (non-negative, summing to 1)")
        for name, value in (("transitions", P), ("reward", reward), ("terminal_reward", w),
                            ("horizon", int(self.horizon)), ("initial", p0)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "n_states", n_states)
        object.__setattr__(self, "n_actions", n_actions)

    @property
    def is_sparse(self):
        return sp.issparse(self.transitions)

    def dense_transitions(self):
        """S(x, a, x') as a dense ``(X, A, X)`` array."""
        P = self.transitions.toarray() if self.is_sparse else self.transitions
        return P.reshape(self.n_states, self.n_actions, self.n_states)


def _check_transitions(S):
    """Return S as a ``(X*A, X)`` float array or CSR matrix, checking it is stochastic."""
    if sp.issparse(S):
        if S.ndim != 2 or S.shape[1] == 0 or S.shape[0] % S.shape[1]:
            raise ValueError(f"transitions: a sparse S must have shape (X*A, X), got {S.shape}")
        P = sp.csr_matrix(S, dtype=float)
        P.sum_duplicates()
        values, row_sums = P.data, np.asarray(P.sum(axis=1)).ravel()
        n_states = S.shape[1]
    else:
        S = np.asarray(S, dtype=float)
        if S.ndim != 3 or S.shape[0] != S.shape[2] or S.shape[0] == 0 or S.shape[1] == 0:
            raise ValueError(f"transitions: a dense S must have shape (X, A, X), got {S.shape}")
        n_states = S.shape[0]
        P = np.ascontiguousarray(S.reshape(-1, n_states))
        values, row_sums = P, P.sum(axis=1)
    if not np.all(np.isfinite(values)) or np.any(values < 0):
        raise ValueError("transitions: S must be finite and non-negative")
    bad = np.flatnonzero(np.abs(row_sums - 1.0) > _ATOL)
    if bad.size:
        x, a = divmod(int(bad[0]), P.shape[0] // n_states)
        raise ValueError(f"transitions: S(x, a, .) must sum to 1; S({x}, {a}, .) sums to {row_sums[bad[0]]:.6g}")
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
    """Validate an allowed-action mask Phi_C: boolean (X, A) or (X, A, K); None means all allowed."""
    if mask is None:
        return np.ones((mdp.n_states, mdp.n_actions), dtype=bool)
    mask = np.asarray(mask)
    if mask.dtype != bool:
        raise ValueError(f"{name}: must be a boolean array, got dtype {mask.dtype}")
    if mask.ndim not in (2, 3) or mask.shape[:2] != (mdp.n_states, mdp.n_actions):
        raise ValueError(f"{name}: shape {mask.shape} should be (X, A) or (X, A, K) with (X, A) = "
                         f"{(mdp.n_states, mdp.n_actions)}")
    return mask


def soft_bellman_backup(mdp, mask=None):
    """The constrained soft Bellman backup, eqs. (2.19)-(2.21), for one constraint set.

    Returns ``(V, Q)`` with V of shape (T+1, X) (V[T] = w, V[0] = log Z) and
    Q of shape (T, X, A) (Q = -inf for forbidden actions).
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

    A state with no allowed action (V = -inf) gets an all-zero row.
    """
    V, Q = soft_bellman_backup(mdp, mask)
    with np.errstate(invalid="ignore"):
        pi = np.exp(Q - V[:-1, :, None])
    return np.nan_to_num(pi, nan=0.0)


# ---------------------------------------------------------------- demonstrations

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
    last row (t = L, the state reached). For a :class:`mutual.mdp.Gridworld`,
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


# ---------------------------------------------------------------- gridworld

GRID_ACTIONS = ("E", "NE", "N", "NW", "W", "SW", "S", "SE", "loiter")
GRID_DELTAS = np.array([(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1), (0, 0)])


@dataclass(frozen=True, eq=False)
class Gridworld:
    """A W x H gridworld MDP (Section 3.3) and its layout; state = col + width * row."""

    width: int
    height: int
    start: tuple
    goal: tuple
    slip: float
    mdp: MDP

    def state(self, col, row):
        return col + self.width * row

    def coords(self, state):
        """(col, row) of a state index (or arrays of them)."""
        return np.asarray(state) % self.width, np.asarray(state) // self.width

    def label(self, kind, index):
        """'state (col, row)' or 'action NE' for a ``kind`` ("state"/"action") and its index."""
        if kind == "state":
            return "state ({}, {})".format(*(int(v) for v in self.coords(index)))
        return f"action {GRID_ACTIONS[index]}"


def gridworld(width, height, start, goal, slip=0.1, horizon=None, miss_penalty=50.0, sparse=False):
    """The thesis's gridworld (Section 3.3).

    Actions: the eight compass moves ``GRID_ACTIONS[:8]`` and ``loiter``. A move
    goes in its commanded direction with probability 1 - ``slip`` and otherwise
    in one of the other seven compass directions (``slip / 7`` each); loitering
    stays put surely. Off-grid rule: a commanded move off the grid leaves the
    agent in place, and a slip never leaves the grid -- the slip probability is
    spread evenly over the other directions that stay on it (so a slip never
    lands the agent back where it stood). Reward: r(x, a) = -(length of the commanded move): 1 for
    orthogonal, sqrt(2) for diagonal moves, 0 for loitering, so the agent
    minimises the distance it travels and loiters free of charge once at the
    goal. Terminal reward: 0 at the goal and -``miss_penalty`` elsewhere, so the
    agent must reach the goal within ``horizon`` steps (default 2 max(W, H), room
    for a detour around a constraint).
    The agent starts at ``start``; positions are (col, row), row 0 at the bottom.
    """
    for name, v in (("width", width), ("height", height)):
        if not isinstance(v, (int, np.integer)) or v < 2:
            raise ValueError(f"{name}: must be an integer >= 2, got {v!r}")
    for name, (c, r) in (("start", start), ("goal", goal)):
        if not (0 <= c < width and 0 <= r < height):
            raise ValueError(f"{name}: {(c, r)} is off the {width} x {height} grid")
    if not 0 <= slip <= 1:
        raise ValueError(f"slip: must lie in [0, 1], got {slip!r}")
    horizon = 2 * max(width, height) if horizon is None else horizon
    X, A = width * height, len(GRID_ACTIONS)
    col, row = np.arange(X) % width, np.arange(X) // width
    nc, nr = col[:, None] + GRID_DELTAS[None, :8, 0], row[:, None] + GRID_DELTAS[None, :8, 1]
    on_grid = (nc >= 0) & (nc < width) & (nr >= 0) & (nr < height)                  # (X, 8)
    landing = np.where(on_grid, nc + width * nr, np.arange(X)[:, None])             # (X, 8)
    commanded = np.eye(8, dtype=bool)[None]                                           # (1, a, d)
    slips = on_grid[:, None, :] & ~commanded                                          # (X, a, d)
    prob = np.where(commanded, 1.0 - slip, slip * slips / slips.sum(axis=2, keepdims=True))
    rows = np.concatenate([np.repeat(np.arange(X)[:, None] * A + np.arange(8), 8), np.arange(X) * A + 8])
    cols = np.concatenate([np.broadcast_to(landing[:, None, :], (X, 8, 8)).ravel(), np.arange(X)])
    vals = np.concatenate([prob.ravel(), np.ones(X)])
    keep = vals > 0
    P = sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(X * A, X))
    reward = -np.broadcast_to(np.hypot(GRID_DELTAS[:, 0], GRID_DELTAS[:, 1]), (X, A))
    g = goal[0] + width * goal[1]
    w = np.full(X, -float(miss_penalty))
    w[g] = 0.0
    p0 = np.zeros(X)
    p0[start[0] + width * start[1]] = 1.0
    S = P if sparse else P.toarray().reshape(X, A, X)
    return Gridworld(width, height, tuple(start), tuple(goal), float(slip),
                     MDP(S, reward, horizon, terminal_reward=w, initial=p0))
