"""A gridworld read from a TOML file (the ``--world`` of ``mutual constraints infer``): the MDP
of Section 3.3 that demonstrations are checked against and constraints are inferred on.

The file (every key; see ``data/README.md``)::

    width = 9              # columns, integer >= 2
    height = 9             # rows, integer >= 2
    start = [0, 0]         # [col, row] where every demonstration starts; row 0 is the bottom row
    goal = [8, 0]          # [col, row] of the goal
    slip = 0.1             # chance in [0, 1] that a move goes in one of the other seven directions
    horizon = 18           # optional: steps T (integer >= 1; default 2 * max(width, height))
    miss_penalty = 50.0    # optional: terminal reward -miss_penalty when not at the goal at T
                           #   (>= 0, default 50); the running reward is -(length of the move)
    loiter = "goal"        # optional: where the loiter action is allowed, "goal" (the thesis's
                           #   terminal action, the default) or "anywhere"

States are numbered ``col + width * row``; actions follow
:data:`mutual.constraints.gridworld.GRID_ACTIONS` (E, NE, N, NW, W, SW, S, SE, loiter = 0..8).
"""

from ..inputs import Keys, read_toml
from .gridworld import gridworld, miss_penalty_limit, size_problem

LOITER_RULES = ("goal", "anywhere")
_KEYS = ("width", "height", "start", "goal", "slip", "horizon", "miss_penalty", "loiter")
_REQUIRED = ("width", "height", "start", "goal", "slip")


def _cell(keys, key, width, height):
    v = keys.get(key)
    if (not isinstance(v, list) or len(v) != 2
            or not all(isinstance(c, int) and not isinstance(c, bool) for c in v)):
        keys.fail(key, f"must be [col, row], two integers, got {v!r}")
    col, row = v
    if not (0 <= col < width and 0 <= row < height):
        keys.fail(key, f"[{col}, {row}] is off the {width} x {height} grid (col 0..{width - 1}, row 0..{height - 1})")
    return (col, row)


def world_from_mapping(mapping, source="world"):
    """Check a world (a dict, as TOML reads it) and build its :class:`~mutual.constraints.gridworld.Gridworld`.

    Raises ValueError naming ``source`` and the key for a missing, unknown or out-of-range key.
    """
    keys = Keys(mapping, source).known(_KEYS, _REQUIRED)
    width = keys.number("width", low=2, integer=True)
    height = keys.number("height", low=2, integer=True)
    start = _cell(keys, "start", width, height)
    goal = _cell(keys, "goal", width, height)
    slip = keys.number("slip", 0.0, 1.0)
    horizon = keys.number("horizon", low=1, integer=True, default=None)
    miss_penalty = keys.number("miss_penalty", low=0.0, default=50.0)
    loiter = keys.choice("loiter", LOITER_RULES, default="goal")
    steps = horizon if horizon is not None else 2 * max(width, height)
    problem = size_problem(width, height, steps)     # before anything is allocated
    if problem:
        keys.fail(problem[0] if problem[0] != "horizon" or horizon is not None else "width", problem[1])
    if miss_penalty > miss_penalty_limit(steps):
        keys.fail("miss_penalty", f"{miss_penalty:g} is too large (at most {miss_penalty_limit(steps):.3g}: soft values "
                                  "this large lose every digit of the policy)")
    return gridworld(width, height, start, goal, slip=slip, horizon=horizon, miss_penalty=miss_penalty,
                     loiter=loiter)


def load_world(path):
    """Read a world TOML file (module docstring) and build its gridworld; errors name the file and the key."""
    return world_from_mapping(read_toml(path), str(path))
