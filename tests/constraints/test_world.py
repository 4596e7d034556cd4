"""The world TOML loader (``mutual.constraints.world``): what it refuses, table-driven, naming the file and
the key (worlds too large for memory named with the memory they need); and that what it builds is the
gridworld its keys describe."""

import tomllib
from pathlib import Path

import numpy as np
import pytest

from mutual.constraints import gridworld
from mutual.constraints.gridworld import GRID_ACTIONS
from mutual.constraints.world import load_world, world_from_mapping


EXAMPLE = Path(__file__).resolve().parents[2] / "data" / "examples" / "world.toml"
BASE = {"width": 4, "height": 3, "start": [0, 0], "goal": [3, 0], "slip": 0.1}


def world_with(**changes):
    d = {**BASE, **changes}
    return {k: v for k, v in d.items() if v is not None}


BAD = [
    (world_with(width=None), "key 'width': missing"),
    (world_with(height=None), "key 'height': missing"),
    (world_with(start=None), "key 'start': missing"),
    (world_with(goal=None), "key 'goal': missing"),
    (world_with(slip=None), "key 'slip': missing"),
    (world_with(colour="blue"), "key 'colour': unknown key"),
    (world_with(reward=-1), "key 'reward': unknown key"),
    (world_with(width=1), "key 'width': must be an integer >= 2"),
    (world_with(width=4.0), "key 'width': must be an integer"),
    (world_with(width=True), "key 'width': must be an integer"),
    (world_with(height="3"), "key 'height': must be an integer"),
    (world_with(start=[0]), "key 'start': must be [col, row]"),
    (world_with(start=[0, 0.5]), "key 'start': must be [col, row]"),
    (world_with(start=[4, 0]), "key 'start': [4, 0] is off the 4 x 3 grid"),
    (world_with(goal=[0, -1]), "key 'goal': [0, -1] is off"),
    (world_with(goal=[0, 3]), "key 'goal': [0, 3] is off"),
    (world_with(slip=1.5), "key 'slip': must be a number in [0, 1]"),
    (world_with(slip=-0.1), "key 'slip'"),
    (world_with(slip=float("nan")), "key 'slip'"),
    (world_with(slip="0.1"), "key 'slip'"),
    (world_with(horizon=0), "key 'horizon': must be an integer >= 1"),
    (world_with(horizon=10.5), "key 'horizon'"),
    (world_with(miss_penalty=-50), "key 'miss_penalty': must be a non-negative finite number"),
    (world_with(miss_penalty=float("inf")), "key 'miss_penalty'"),
    (world_with(loiter="never"), "key 'loiter': must be one of ['goal', 'anywhere']"),
    (world_with(loiter=1), "key 'loiter'"),
]


@pytest.mark.parametrize("mapping, phrase", BAD)
def test_bad_worlds_are_refused_naming_the_key(mapping, phrase):
    with pytest.raises(ValueError) as err:
        world_from_mapping(mapping, "w.toml")
    assert str(err.value).startswith("w.toml: ") and phrase in str(err.value)


@pytest.mark.parametrize("text, phrase", [
    ("width = 4\nheight = \n", "not valid TOML"),
    ("width = 4\nwidth = 5\n", "not valid TOML"),
    ("[grid]\nwidth = 4\n", "key 'grid': unknown key"),
    ("", "key 'width': missing"),
])
def test_bad_files_name_the_file(tmp_path, text, phrase):
    path = tmp_path / "w.toml"
    path.write_text(text)
    with pytest.raises(ValueError) as err:
        load_world(path)
    assert str(err.value).startswith(f"{path}: ") and phrase in str(err.value)


def test_a_missing_file_is_a_file_not_found_error(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_world(tmp_path / "nowhere.toml")


def test_the_world_is_the_gridworld_its_keys_describe():
    world = world_from_mapping(world_with(horizon=7, miss_penalty=20.0, loiter="anywhere"))
    same = gridworld(4, 3, (0, 0), (3, 0), slip=0.1, horizon=7, miss_penalty=20.0, loiter="anywhere")
    assert (world.width, world.height, world.start, world.goal, world.slip) == (4, 3, (0, 0), (3, 0), 0.1)
    assert world.mdp.horizon == 7
    assert np.array_equal(np.asarray(world.mdp.transitions), np.asarray(same.mdp.transitions))
    assert np.array_equal(world.mdp.terminal_reward, same.mdp.terminal_reward)
    assert world.mdp.terminal_reward.min() == -20.0


def test_defaults_are_the_thesis_rules():
    """horizon 2 max(W, H), miss penalty 50, loitering only at the goal (Section 3.3)."""
    world = world_from_mapping(BASE)
    assert world.mdp.horizon == 2 * 4 and world.mdp.terminal_reward.min() == -50.0
    loiter = GRID_ACTIONS.index("loiter")
    allowed = world.mdp.allowed[:, loiter]
    assert allowed[world.state(3, 0)] and allowed.sum() == 1
    assert world_from_mapping(world_with(loiter="anywhere")).mdp.allowed[:, loiter].all()


def test_the_example_world_is_the_chapter_3_world():
    text = EXAMPLE.read_text()
    world = load_world(EXAMPLE)
    assert (world.width, world.height, world.start, world.goal, world.slip) == (9, 9, (0, 0), (8, 0), 0.1)
    assert tomllib.loads(text)["loiter"] == "goal"


LARGE_BASE = {"width": 5, "height": 4, "start": [0, 0], "goal": [4, 0], "slip": 0.1}


LIMITS = [  # (world keys over BASE, the key named, the memory named)
    ({"width": 300, "height": 300, "goal": [8, 0]}, "width", "543 GiB for its transitions"),
    ({"width": 2, "height": 5000, "goal": [1, 0]}, "height", "6.71 GiB for its transitions"),
    ({"horizon": 100_000_000}, "horizon", "268 GiB for its soft policy"),
    ({"horizon": 2 ** 63 - 1}, "horizon", "2.47e\\+13 GiB for its soft policy"),
    ({"width": 2 ** 62, "height": 2 ** 62}, "width", "3.03e\\+67 GiB for its transitions"),
    ({"width": 90, "height": 90, "goal": [8, 0]}, "width", "4.4 GiB for its transitions"),
]


@pytest.mark.parametrize("keys, key, memory", LIMITS)
def test_a_world_too_large_for_memory_is_refused_naming_key_and_memory(keys, key, memory):
    with pytest.raises(ValueError, match=f"^world.toml: key '{key}': .*needs {memory}.*over the limit of 4 GiB"):
        world_from_mapping({**LARGE_BASE, **keys}, "world.toml")


@pytest.mark.parametrize("penalty, horizon", [(1e300, None), (1.000001e100, 10), (1e101, None)])
def test_a_huge_miss_penalty_is_named_as_such_not_as_reward(penalty, horizon):
    keys = {**LARGE_BASE, "miss_penalty": penalty} | ({"horizon": horizon} if horizon else {})
    with pytest.raises(ValueError, match="^world.toml: key 'miss_penalty': .* is too large"):
        world_from_mapping(keys, "world.toml")
    with pytest.raises(ValueError, match="^miss_penalty: .* is too large"):
        gridworld(5, 4, (0, 0), (4, 0), miss_penalty=penalty, horizon=horizon)
