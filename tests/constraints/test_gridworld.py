"""The gridworld of Section 3.3: its transitions and rewards against the text's rules, loitering offered
at the goal only, and the memory limit checked before anything is allocated; its bad inputs (a table)."""

import numpy as np
import pytest

from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.experiment import measured_dynamics
from mutual.constraints.gridworld import GRID_ACTIONS, MAX_BYTES, gridworld
from mutual.constraints.mdp import soft_policy


def test_gridworld_transitions_and_rewards():
    g = gridworld(4, 3, (0, 0), (3, 0), slip=0.1)
    S = g.mdp.dense_transitions()
    np.testing.assert_allclose(S.sum(axis=2), 1.0)
    E, loiter = GRID_ACTIONS.index("E"), GRID_ACTIONS.index("loiter")
    x = g.state(1, 1)                      # interior: 0.9 ahead, 0.1 / 7 to each other neighbour
    assert S[x, E, g.state(2, 1)] == pytest.approx(0.9)
    assert S[x, E, g.state(0, 0)] == pytest.approx(0.1 / 7)
    assert S[x, loiter, x] == 1.0
    corner = g.state(0, 0)                 # commanded off-grid: stay; slips only onto the grid
    W = GRID_ACTIONS.index("W")
    assert S[corner, W, corner] == pytest.approx(0.9)
    assert S[corner, W, g.state(1, 0)] == pytest.approx(0.1 / 3)
    assert S[corner, E, corner] == 0.0
    assert g.mdp.reward[x, E] == -1.0 and g.mdp.reward[x, 1] == pytest.approx(-np.sqrt(2))
    assert g.mdp.reward[x, loiter] == 0.0
    assert g.mdp.terminal_reward[g.state(3, 0)] == 0.0 and g.mdp.terminal_reward[x] < 0
    sparse = gridworld(4, 3, (0, 0), (3, 0), slip=0.1, sparse=True)
    np.testing.assert_array_equal(sparse.mdp.dense_transitions(), S)


@pytest.mark.parametrize("kwargs, message", [
    (dict(width=1), "width"), (dict(start=(9, 0)), "start"), (dict(goal=(0, -1)), "goal"), (dict(slip=1.5), "slip"),
])
def test_bad_gridworld_inputs_raise_clear_errors(kwargs, message):
    args = dict(width=4, height=4, start=(0, 0), goal=(3, 0))
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        gridworld(**args)


LOITER = GRID_ACTIONS.index("loiter")


def test_loiter_is_offered_at_the_goal_only_by_default():
    g = gridworld(5, 4, (0, 0), (4, 0))
    goal = g.state(4, 0)
    assert g.mdp.allowed[:, LOITER].sum() == 1 and g.mdp.allowed[goal, LOITER]
    assert g.mdp.allowed[:, :LOITER].all()
    pi = soft_policy(g.mdp)
    assert np.all(pi[:, np.arange(20) != goal, LOITER] == 0)
    demos = sample_demonstrations(g.mdp, 200, rng=0)
    loitering = demos.actions == LOITER
    assert np.all(demos.states[:, :-1][loitering] == goal) and loitering.any()
    anywhere = gridworld(5, 4, (0, 0), (4, 0), loiter="anywhere")
    assert anywhere.mdp.allowed.all()
    assert measured_dynamics(g)["matches_text"] and not measured_dynamics(anywhere)["matches_text"]
    # the structural mask is part of every backup: the same mask with loiter allowed changes nothing
    everything = np.ones((20, 9), dtype=bool)
    np.testing.assert_array_equal(soft_policy(g.mdp, everything), pi)


def test_the_limit_is_checked_by_the_library_too_and_a_world_below_it_builds():
    with pytest.raises(ValueError, match="^width: a 300 x 300 world needs 543 GiB"):
        gridworld(300, 300, (0, 0), (8, 0))
    assert gridworld(30, 30, (0, 0), (8, 0), horizon=60).mdp.n_states == 900   # 52 MB
    assert 8 * 90 * 90 * 90 * 90 * 9 > MAX_BYTES > 8 * 80 ** 4 * 9


def _grid(**kwargs):
    return gridworld(**{**dict(width=4, height=4, start=(0, 0), goal=(3, 0)), **kwargs})


CASES = [
    # gridworld (Section 3.3)
    (_grid, (), dict(width=1), ValueError, "width"),
    (_grid, (), dict(width=4.0), ValueError, "width"),
    (_grid, (), dict(start=(4, 0)), ValueError, "start"),
    (_grid, (), dict(start=(0.5, 0)), ValueError, "start"),
    (_grid, (), dict(goal=(3, -1)), ValueError, "goal"),
    (_grid, (), dict(slip=1.5), ValueError, "slip"),
    (_grid, (), dict(slip=float("nan")), ValueError, "slip"),
    (_grid, (), dict(miss_penalty=-50), ValueError, "miss_penalty"),
    (_grid, (), dict(miss_penalty=float("inf")), ValueError, "miss_penalty"),
    (_grid, (), dict(loiter="sometimes"), ValueError, "loiter"),
    (_grid, (), dict(horizon=0), ValueError, "horizon"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i:02d}-{case[0].__name__}" for i, case in enumerate(CASES)])
def test_bad_input_raises_a_clear_error(fn, args, kwargs, error, phrase):
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value), f"message {str(info.value)!r} should mention {phrase!r}"
