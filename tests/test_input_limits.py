"""Chapters 2-4 inputs as users write them (issue 22, sections 1 and 3): TOML with a byte-order mark,
interventions outside the grid named by their line in the file's own coordinates, worlds too large
for memory refused before anything is allocated (naming the key and the memory), and the remaining
raw errors (seeds, a float32 slip, a huge miss_penalty, overflow) named by their input."""

import codecs
import numpy as np
import pytest
import scipy.sparse as sp

from mutual.constraints.demonstrations import load_demonstrations, sample_demonstrations
from mutual.constraints.gridworld import MAX_BYTES, gridworld
from mutual.constraints.mdp import MDP
from mutual.constraints.world import load_world, world_from_mapping
from mutual.seeds import generator
from mutual.supervision.dubins import unsafe_reach
from mutual.supervision.reachability import QUICK_GRID, value_library
from mutual.supervision.supervisor import check_inside, read_interventions
from mutual.inputs import read_toml

WORLD = "width = 5\nheight = 4\nstart = [0, 0]\ngoal = [4, 0]\nslip = 0.1\n"
BASE = {"width": 5, "height": 4, "start": [0, 0], "goal": [4, 0], "slip": 0.1}


# -- friendly formats ---------------------------------------------------------------------------------

@pytest.mark.parametrize("encoding, text", [
    ("a UTF-8 byte-order mark", codecs.BOM_UTF8 + WORLD.encode()),
    ("a byte-order mark and CRLF line ends", codecs.BOM_UTF8 + WORLD.replace("\n", "\r\n").encode()),
    ("plain UTF-8", WORLD.encode()),
])
def test_a_world_file_with_a_byte_order_mark_reads_as_without(tmp_path, encoding, text):
    path = tmp_path / "world.toml"
    path.write_bytes(text)
    assert read_toml(path) == read_toml_text(WORLD)
    grid = load_world(path)
    assert (grid.width, grid.height, grid.goal) == (5, 4, (4, 0))


def read_toml_text(text):
    import tomllib
    return tomllib.loads(text)


@pytest.mark.parametrize("what, data, message", [
    ("UTF-16 text", WORLD.encode("utf-16"), r"not valid TOML \(not UTF-8 text"),
    ("a byte-order mark only", codecs.BOM_UTF8, r"key 'width': missing"),
    ("a byte-order mark twice", codecs.BOM_UTF8 * 2 + WORLD.encode(), r"not valid TOML"),
])
def test_other_encodings_are_named(tmp_path, what, data, message):
    path = tmp_path / "world.toml"
    path.write_bytes(data)
    with pytest.raises(ValueError, match=f"{path}: .*{message}"):
        load_world(path)


HEADER = "participant,trial,time,x,y,theta,obstacle_x,obstacle_y\n"
OUTSIDE = [  # (rows after the header, the line named, what the message shows)
    ("P1,0,1,-3,0,0,0,0\nP1,0,2,10,2,0,0,0\n", 3, "x = 10, y = 2 lies outside"),
    ("P1,0,1,52,2,0,40,0\nP1,0,2,-3,0,0,0,0\n", 2, "x = 52, y = 2 lies outside .* around the obstacle at \\(40, 0\\)"),
    ("\nP1,0,1,-3,0,0,0,0\n\nP1,0,2,0,-9,0,0,0\n", 5, "x = 0, y = -9 lies outside"),   # blank lines count
    ("P1,0,1,-3,0,0,0,0\nP1,0,2,0,-9,0,0,0\nP1,0,3,9,9,0,0,0\n", 3, r"x = 0, y = -9 .*\(1 more rows like it\)"),
    ("P1,0,1,1e308,0,0,-1e308,0\n", 2, "x = 1e\\+308, y = 0 lies outside"),
]


@pytest.mark.parametrize("rows, line, shown", OUTSIDE)
def test_an_intervention_outside_the_grid_names_its_line_in_the_files_coordinates(tmp_path, rows, line, shown):
    path = tmp_path / "interventions.csv"
    path.write_text(HEADER + rows)
    frame = read_interventions(path)
    with pytest.raises(ValueError, match=f"{path}, line {line}: the intervention at {shown}"):
        check_inside(frame, QUICK_GRID.half_width, path)


@pytest.mark.parametrize("rows", ["P1,0,1,8,-8,0,0,0\n", "P1,0,1,47,7.5,0,40,0\n", "P1,0,1,-7.99,3,9,0,0\n"])
def test_interventions_inside_the_grid_pass(tmp_path, rows):
    path = tmp_path / "interventions.csv"
    path.write_text(HEADER + rows)
    check_inside(read_interventions(path), QUICK_GRID.half_width, path)


# -- limits that name their key -------------------------------------------------------------------------

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
        world_from_mapping({**BASE, **keys}, "world.toml")


def test_the_limit_is_checked_by_the_library_too_and_a_world_below_it_builds():
    with pytest.raises(ValueError, match="^width: a 300 x 300 world needs 543 GiB"):
        gridworld(300, 300, (0, 0), (8, 0))
    assert gridworld(30, 30, (0, 0), (8, 0), horizon=60).mdp.n_states == 900   # 52 MB
    assert 8 * 90 * 90 * 90 * 90 * 9 > MAX_BYTES > 8 * 80 ** 4 * 9


@pytest.mark.parametrize("penalty, horizon", [(1e300, None), (1.000001e100, 10), (1e101, None)])
def test_a_huge_miss_penalty_is_named_as_such_not_as_reward(penalty, horizon):
    keys = {**BASE, "miss_penalty": penalty} | ({"horizon": horizon} if horizon else {})
    with pytest.raises(ValueError, match="^world.toml: key 'miss_penalty': .* is too large"):
        world_from_mapping(keys, "world.toml")
    with pytest.raises(ValueError, match="^miss_penalty: .* is too large"):
        gridworld(5, 4, (0, 0), (4, 0), miss_penalty=penalty, horizon=horizon)


# -- seeds, dtypes and overflow -----------------------------------------------------------------------------

@pytest.mark.parametrize("seed", [-1, float("nan"), 1.5, True, "3", 2.0, np.float64(3), [-1]])
def test_a_seed_that_is_not_a_non_negative_integer_is_named(seed):
    grid = gridworld(5, 4, (0, 0), (4, 0))
    with pytest.raises(ValueError, match=r"^rng: must be a non-negative integer \(or a numpy Generator\), got "):
        sample_demonstrations(grid.mdp, 2, rng=seed)


@pytest.mark.parametrize("seed", [0, 7, np.int64(7), np.uint8(7), None, np.random.default_rng(7)])
def test_valid_seeds_give_generators(seed):
    rng = generator(seed)
    assert isinstance(rng, np.random.Generator)
    if seed is not None and not isinstance(seed, np.random.Generator):
        assert rng.random() == np.random.default_rng(int(seed)).random()


@pytest.mark.parametrize("dtype", [np.float32, np.float16])
def test_a_lower_precision_slip_or_transition_matrix_is_stochastic(dtype):
    grid = gridworld(9, 9, (0, 0), (8, 0), slip=dtype(0.1))
    assert grid.slip == float(dtype(0.1)) and grid.mdp.transitions.dtype == np.float64
    reference = gridworld(9, 9, (0, 0), (8, 0)).mdp
    S = reference.dense_transitions().astype(dtype)
    for given in (S, sp.csr_matrix(S.reshape(-1, 81))) if dtype == np.float32 else (S,):
        mdp = MDP(given, reference.reward, reference.horizon)
        sums = np.asarray(mdp.transitions.sum(axis=1)).ravel()
        assert np.abs(sums - 1).max() <= 1e-15


@pytest.mark.parametrize("dtype, off", [(np.float32, 1e-2), (np.float64, 1e-8), (np.float16, 0.2)])
def test_a_matrix_whose_rows_do_not_sum_to_one_in_its_own_precision_is_refused(dtype, off):
    reference = gridworld(5, 4, (0, 0), (4, 0)).mdp
    S = reference.dense_transitions().astype(dtype)
    S[2, 1, :] *= dtype(1 + off)
    with pytest.raises(ValueError, match=r"S\(2, 1, .\) sums to"):
        MDP(S, reference.reward, reference.horizon)


@pytest.mark.parametrize("radius, speed, w_max", [(1e308, 3.0, 1.0), (1.0, 1e308, 1e-10), (1e200, 1e200, 1e-200)])
def test_huge_inputs_of_the_reach_do_not_overflow(radius, speed, w_max):
    reach = unsafe_reach(w_max, radius, speed)
    assert reach >= radius
    with pytest.raises(ValueError, match="half_width=8.0 is too small.*obstacle radius"):
        value_library([w_max, 2 * w_max], radius, QUICK_GRID, speed=speed, progress=False)


@pytest.mark.parametrize("text", ["99999999999999999999999", "1e30", "-1e300"])
def test_a_huge_state_in_the_demonstrations_is_named_as_written(tmp_path, text):
    path = tmp_path / "demos.csv"
    path.write_text(f"demo,t,state,action\n0,0,0,0\n0,1,{text},\n")
    with pytest.raises(ValueError, match=f"line 3, column 'state': '{text}' is too large"):
        load_demonstrations(path, gridworld(5, 4, (0, 0), (4, 0)).mdp)
