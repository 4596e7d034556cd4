"""Demonstrations: sampled ones follow the soft policy, the CSV round-trips exactly, and the loader
names the file, the line and the column of what it refuses (tables of input -> message)."""

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mutual.constraints.chance import constraint_mask
from mutual.constraints.demonstrations import (Demonstrations, check_demonstrations, demonstration_log_likelihood,
                                               load_demonstrations, sample_demonstrations, write_demonstrations)
from mutual.constraints.gridworld import GRID_ACTIONS, gridworld
from mutual.constraints.mdp import soft_bellman_backup, soft_policy


def test_sampled_demonstrations_follow_the_policy():
    g = gridworld(3, 3, (0, 0), (2, 0), slip=0.2, horizon=3)
    mdp = g.mdp
    demos = sample_demonstrations(mdp, 20000, rng=5)
    pi0 = soft_policy(mdp)[0, g.state(0, 0)]
    freq = np.bincount(demos.actions[:, 0], minlength=9) / demos.n
    np.testing.assert_allclose(freq, pi0, atol=0.015)
    check_demonstrations(mdp, demos)
    again = sample_demonstrations(mdp, 50, rng=5)
    np.testing.assert_array_equal(again.states, sample_demonstrations(mdp, 50, rng=5).states)


def test_demonstrations_csv_round_trip(tmp_path):
    g = gridworld(4, 4, (0, 0), (3, 0))
    demos = sample_demonstrations(g.mdp, 7, rng=1)
    path = write_demonstrations(tmp_path / "demos.csv", demos)
    back = load_demonstrations(path, g.mdp)
    np.testing.assert_array_equal(back.states, demos.states)
    np.testing.assert_array_equal(back.actions, demos.actions)
    assert demonstration_log_likelihood(g.mdp, back) == demonstration_log_likelihood(g.mdp, demos)


@pytest.mark.parametrize("edit, message", [
    (lambda df: df.assign(state=df["state"].where(df.index != 3, 99)), "unknown state"),
    (lambda df: df.assign(action=df["action"].where(df.index != 2, 12)), "unknown action"),
    (lambda df: df.drop(columns="action"), "missing column 'action'"),
    (lambda df: df.assign(t=df["t"].where(df.index != 2, 7)), "t must run"),
])
def test_loader_rejects_bad_files(tmp_path, edit, message):
    import pandas as pd
    g = gridworld(4, 4, (0, 0), (3, 0))
    path = write_demonstrations(tmp_path / "demos.csv", sample_demonstrations(g.mdp, 3, rng=2))
    edit(pd.read_csv(path)).to_csv(path, index=False)
    with pytest.raises(ValueError, match=message):
        load_demonstrations(path, g.mdp)


def test_loader_rejects_impossible_transitions(tmp_path):
    g = gridworld(4, 4, (0, 0), (3, 0), slip=0.0)
    states = np.array([[0, 1, 2]])
    actions = np.array([[GRID_ACTIONS.index("E"), GRID_ACTIONS.index("W")]])   # W from 1 cannot reach 2
    path = write_demonstrations(tmp_path / "demos.csv", Demonstrations(states, actions))
    with pytest.raises(ValueError, match="zero probability"):
        load_demonstrations(path, g.mdp)


def test_bad_masks_and_demonstrations_raise_clear_errors():
    g = gridworld(3, 3, (0, 0), (2, 0))
    with pytest.raises(ValueError, match="mask"):
        soft_bellman_backup(g.mdp, np.ones((9, 9)))
    with pytest.raises(ValueError, match="mask"):
        soft_bellman_backup(g.mdp, np.ones((9, 8), dtype=bool))
    with pytest.raises(ValueError, match="states/actions"):
        Demonstrations(np.zeros((2, 3), dtype=int), np.zeros((2, 3), dtype=int))
    with pytest.raises(ValueError, match="exceed the horizon"):
        check_demonstrations(g.mdp, Demonstrations(np.zeros((1, 40), dtype=int), np.full((1, 39), 8)))


@pytest.mark.parametrize("seed", [-1, float("nan"), 1.5, True, "3", 2.0, np.float64(3), [-1]])
def test_a_seed_that_is_not_a_non_negative_integer_is_named(seed):
    grid = gridworld(5, 4, (0, 0), (4, 0))
    with pytest.raises(ValueError, match=r"^rng: must be a non-negative integer \(or a numpy Generator\), got "):
        sample_demonstrations(grid.mdp, 2, rng=seed)


@pytest.mark.parametrize("text", ["99999999999999999999999", "1e30", "-1e300", "9007199254740993", "9007199254740992",
                                  "-9007199254740993"])
def test_a_huge_state_in_the_demonstrations_is_named_as_written(tmp_path, text):
    path = tmp_path / "demos.csv"
    path.write_text(f"demo,t,state,action\n0,0,0,0\n0,1,{text},\n")
    with pytest.raises(ValueError, match=f"line 3, column 'state': '{text}' is too large"):
        load_demonstrations(path, gridworld(5, 4, (0, 0), (4, 0)).mdp)


G = gridworld(4, 4, (0, 0), (3, 0))
MDP0 = G.mdp
LOITER = GRID_ACTIONS.index("loiter")


def _written(folder):
    path = Path(folder) / "demos.csv"
    write_demonstrations(path, sample_demonstrations(MDP0, 3, rng=2))
    return path


def _load_edited(edit):
    """Write a valid demonstrations CSV, apply ``edit`` to its text lines, load it."""
    with tempfile.TemporaryDirectory(prefix="mutual-bad-") as folder:
        path = _written(folder)
        lines = path.read_text().splitlines()
        path.write_text("\n".join(edit(lines)) + "\n")
        return load_demonstrations(path, MDP0)


def _replace(line_no, column, value):
    """An edit that sets ``column`` of file line ``line_no`` (1 = header) to ``value``."""
    def edit(lines):
        header = lines[0].split(",")
        cells = lines[line_no - 1].split(",")
        cells[header.index(column)] = value
        lines[line_no - 1] = ",".join(cells)
        return lines
    return edit


def _empty_file():
    with tempfile.TemporaryDirectory(prefix="mutual-bad-") as folder:
        path = Path(folder) / "empty.csv"
        path.write_text("")
        return load_demonstrations(path, MDP0)


def _off_goal_loiter():
    return check_demonstrations(MDP0, Demonstrations(np.array([[0, 0]]), np.array([[LOITER]])))


CASES = [
    # demonstrations
    (Demonstrations, (np.zeros((2, 3), dtype=int), np.zeros((2, 3), dtype=int)), {}, ValueError, "states/actions"),
    (Demonstrations, (np.zeros((1, 3)), np.zeros((1, 2))), {}, ValueError, "integer"),
    (check_demonstrations, (MDP0, Demonstrations(np.array([[0, 1]]), np.array([[12]]))), {}, ValueError, "unknown action"),
    (check_demonstrations, (MDP0, "demos"), {}, TypeError, "demos"),
    (_off_goal_loiter, (), {}, ValueError, "not available"),
    (sample_demonstrations, (MDP0, 0), {}, ValueError, "n"),
    (sample_demonstrations, (MDP0, True), {}, ValueError, "n"),
    (sample_demonstrations, (MDP0, 3, constraint_mask(MDP0, [5], 0.0)), {}, ValueError, "no trajectory"),
    # the demonstrations CSV: file, line and column
    (_empty_file, (), {}, ValueError, "is empty"),
    (_load_edited, (lambda lines: lines[:1],), {}, ValueError, "no data rows"),
    (_load_edited, (lambda lines: [line.rsplit(",", 1)[0] for line in lines],), {}, ValueError, "missing column 'action'"),
    (_load_edited, (_replace(4, "action", "north"),), {}, ValueError, "line 4, column 'action'"),
    (_load_edited, (_replace(10, "action", "99"),), {}, ValueError, "last row"),
    (_load_edited, (_replace(5, "state", "2.5"),), {}, ValueError, "line 5, column 'state'"),
    (_load_edited, (_replace(5, "state", "99"),), {}, ValueError, "unknown state"),
    (_load_edited, (_replace(3, "t", "7"),), {}, ValueError, "column 't'"),
    (_load_edited, (_replace(3, "action", ""),), {}, ValueError, "line 3, column 'action': empty"),
    (_load_edited, (lambda lines: [lines[0]] + [line.replace("1,", "5,", 1) if line.startswith("1,") else line
                                               for line in lines[1:]],), {}, ValueError, "demo ids"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i:02d}-{case[0].__name__}" for i, case in enumerate(CASES)])
def test_bad_input_raises_a_clear_error(fn, args, kwargs, error, phrase):
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value), f"message {str(info.value)!r} should mention {phrase!r}"


def test_loader_messages_name_the_file(tmp_path):
    path = _written(tmp_path)
    df = pd.read_csv(path)
    df.loc[2, "action"] = np.nan
    df.to_csv(path, index=False)
    with pytest.raises(ValueError, match=str(path.name)):
        load_demonstrations(path, MDP0)
