"""The gridworld of Section 3.3: eight compass moves that slip to one of the other seven
directions, a loitering terminal action for once the goal is reached, a running reward of minus
the distance moved, a terminal reward that pays for reaching the goal."""

import numbers
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..inputs import check_number
from .mdp import MAX_VALUE, MDP

MAX_BYTES = 4 * 2 ** 30   # the memory one world may ask for (dense S and the soft policy): 4 GiB

GRID_ACTIONS = ("E", "NE", "N", "NW", "W", "SW", "S", "SE", "loiter")
GRID_DELTAS = np.array([(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1), (0, 0)])
LOITER = GRID_ACTIONS.index("loiter")
LOITER_RULES = ("goal", "anywhere")


@dataclass(frozen=True, eq=False)
class Gridworld:
    """A W x H gridworld MDP (Section 3.3) and its layout; state = col + width * row."""

    width: int
    height: int
    start: tuple
    goal: tuple
    slip: float
    mdp: MDP
    loiter: str = "goal"

    def __repr__(self):
        return (f"Gridworld({self.width} x {self.height}, start {self.start}, goal {self.goal}, slip {self.slip:g}, "
                f"T = {self.mdp.horizon}, loiter at {'the goal only' if self.loiter == 'goal' else 'any cell'})")

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


def _cell(name, value, width, height):
    try:
        c, r = value
    except (TypeError, ValueError):
        raise ValueError(f"{name}: must be a (col, row) pair of integers, got {value!r}") from None
    if any(isinstance(v, bool) or not isinstance(v, (int, np.integer)) for v in (c, r)):
        raise ValueError(f"{name}: must be a (col, row) pair of integers, got {value!r}")
    if not (0 <= c < width and 0 <= r < height):
        raise ValueError(f"{name}: {(c, r)} is off the {width} x {height} grid")
    return int(c), int(r)


def _gib(n_bytes):
    return f"{n_bytes / 2 ** 30:.3g} GiB"


def size_problem(width, height, horizon, sparse=False):
    """``(key, reason)`` when a world this large would ask for more than ``MAX_BYTES`` of memory, else None.

    Counted before anything is allocated: the dense transitions S (``|X|^2 |A|`` floats; the sparse
    S has at most 9 entries per row) and the soft policy and values (``2 (T + 1) |X| |A|`` floats).
    """
    X, A = width * height, len(GRID_ACTIONS)
    transitions = 8 * (X * A * 9 * 2 if sparse else X * X * A)
    if transitions > MAX_BYTES:
        return "width" if width >= height else "height", (f"a {width} x {height} world needs {_gib(transitions)} for its transitions "
                         f"(|X|^2 |A| = {X}^2 x {A} numbers), over the limit of {_gib(MAX_BYTES)}; use a smaller grid")
    policy = 8 * 2 * (horizon + 1) * X * A
    if transitions + policy > MAX_BYTES:
        return "horizon", (f"horizon {horizon} on a {width} x {height} world needs {_gib(transitions + policy)} for "
                           f"its soft policy and values (2 (T + 1) |X| |A| numbers), over the limit of "
                           f"{_gib(MAX_BYTES)}; use a shorter horizon")
    return None


def miss_penalty_limit(horizon):
    """The largest ``miss_penalty`` whose soft values stay representable (``MAX_VALUE`` of the MDP)."""
    return MAX_VALUE - horizon * float(np.sqrt(2))


def gridworld(width, height, start, goal, slip=0.1, horizon=None, miss_penalty=50.0, sparse=False, loiter="goal",
              reward_scale=1.0):
    """The thesis's gridworld (Section 3.3).

    Actions: the eight compass moves ``GRID_ACTIONS[:8]`` and ``loiter``. A move
    goes in its commanded direction with probability 1 - ``slip`` and otherwise
    in one of the other seven compass directions (``slip / 7`` each); loitering
    stays put surely. ``loiter="goal"`` (the thesis: "a loitering terminal action for
    once the goal was reached") offers loiter at the goal only -- elsewhere it is
    unavailable (``MDP.allowed``) and the agent must move every step;
    ``loiter="anywhere"`` offers it in every cell. Off-grid rule: a commanded move
    off the grid leaves the agent in place, and a slip never leaves the grid -- the
    slip probability is spread evenly over the other directions that stay on it (so a
    slip never lands the agent back where it stood). Reward: r(x, a) = -(length of the
    commanded move): 1 for orthogonal, sqrt(2) for diagonal moves, 0 for loitering, so
    the agent minimises the distance it travels. Terminal reward: 0 at the goal and
    -``miss_penalty`` (>= 0) elsewhere, so the agent must reach the goal within
    ``horizon`` steps (default 2 max(W, H), room for a detour around a constraint).
    ``reward_scale`` (> 0) multiplies both rewards: the inverse temperature of the Boltzmann
    demonstrator (eq. 2.19), which the thesis does not state (1: unit temperature).
    The agent starts at ``start``; positions are (col, row), row 0 at the bottom.
    """
    width, height = (check_number(name, v, low=2, integer=True, sep=": ") for name, v in (("width", width),
                                                                                       ("height", height)))
    start, goal = _cell("start", start, width, height), _cell("goal", goal, width, height)
    if isinstance(slip, bool) or not isinstance(slip, numbers.Real) or not 0 <= slip <= 1:
        raise ValueError(f"slip: must be a number in [0, 1], got {slip!r}")
    slip = float(slip)     # a float32 slip would make S float32, whose rows sum to 1 only to 1e-7
    if isinstance(miss_penalty, bool) or not isinstance(miss_penalty, numbers.Real) or not (
            np.isfinite(miss_penalty) and miss_penalty >= 0):
        raise ValueError(f"miss_penalty: must be a finite number >= 0 (a penalty for missing the goal), "
                         f"got {miss_penalty!r}")
    if isinstance(reward_scale, bool) or not isinstance(reward_scale, numbers.Real) or not (
            np.isfinite(reward_scale) and reward_scale > 0):
        raise ValueError(f"reward_scale: must be a finite number > 0 (the demonstrator's inverse temperature), "
                         f"got {reward_scale!r}")
    if loiter not in LOITER_RULES:
        raise ValueError(f"loiter: must be one of {LOITER_RULES}, got {loiter!r}")
    horizon = 2 * max(width, height) if horizon is None else check_number("horizon", horizon, low=1, integer=True,
                                                                           sep=": ")
    if miss_penalty > miss_penalty_limit(horizon):
        raise ValueError(f"miss_penalty: {miss_penalty:g} is too large (at most {miss_penalty_limit(horizon):.3g}: "
                         "soft values this large lose every digit of the policy)")
    problem = size_problem(width, height, horizon, sparse)
    if problem:
        raise ValueError(f"{problem[0]}: {problem[1]}")
    X, A = width * height, len(GRID_ACTIONS)
    col, row = np.arange(X) % width, np.arange(X) // width
    nc, nr = col[:, None] + GRID_DELTAS[None, :8, 0], row[:, None] + GRID_DELTAS[None, :8, 1]
    on_grid = (nc >= 0) & (nc < width) & (nr >= 0) & (nr < height)                  # (X, 8)
    landing = np.where(on_grid, nc + width * nr, np.arange(X)[:, None])             # (X, 8)
    commanded = np.eye(8, dtype=bool)[None]                                           # (1, a, d)
    slips = on_grid[:, None, :] & ~commanded                                          # (X, a, d)
    prob = np.where(commanded, 1.0 - slip, slip * slips / slips.sum(axis=2, keepdims=True))
    rows = np.concatenate([np.repeat(np.arange(X)[:, None] * A + np.arange(8), 8), np.arange(X) * A + LOITER])
    cols = np.concatenate([np.broadcast_to(landing[:, None, :], (X, 8, 8)).ravel(), np.arange(X)])
    vals = np.concatenate([prob.ravel(), np.ones(X)])
    keep = vals > 0
    P = sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(X * A, X))
    reward = -float(reward_scale) * np.broadcast_to(np.hypot(GRID_DELTAS[:, 0], GRID_DELTAS[:, 1]), (X, A))
    g = goal[0] + width * goal[1]
    w = np.full(X, -float(miss_penalty) * float(reward_scale))
    w[g] = 0.0
    p0 = np.zeros(X)
    p0[start[0] + width * start[1]] = 1.0
    allowed = np.ones((X, A), dtype=bool)
    if loiter == "goal":
        allowed[:, LOITER] = False
        allowed[g, LOITER] = True
    S = P if sparse else P.toarray().reshape(X, A, X)
    return Gridworld(width, height, start, goal, float(slip),
                     MDP(S, reward, horizon, terminal_reward=w, initial=p0, allowed=allowed), loiter)
