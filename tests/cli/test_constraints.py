"""``mutual constraints infer`` end to end: it finds a fresh ground-truth constraint, runs on the example, and
refuses malformed files (exit 2, one line naming the file and the column or key; a table)."""

import json

import numpy as np
import pandas as pd
import pytest


from helpers.cli import EXAMPLES, MALFORMED, assert_one_line_error, mutual, no_temporaries, refuses_in_one_line


WORLD = """width = 5\nheight = 4\nstart = [0, 0]\ngoal = [4, 0]\nslip = 0.05\nhorizon = 10\nloiter = "goal"\n"""


def test_constraints_infer_finds_a_fresh_ground_truth_constraint(tmp_path):
    from mutual.constraints import constraint_mask, sample_demonstrations, write_demonstrations
    from mutual.constraints.world import world_from_mapping
    import tomllib
    (tmp_path / "world.toml").write_text(WORLD)
    grid = world_from_mapping(tomllib.loads(WORLD))
    blocked = grid.state(2, 0)                # the middle of the straight path from start to goal
    truth = constraint_mask(grid.mdp, [blocked], 0.25)      # no move aimed at it; slips may land there
    write_demonstrations(tmp_path / "demos.csv", sample_demonstrations(grid.mdp, 80, truth, rng=4))
    run = mutual("constraints", "infer", "demos.csv", "--world", "world.toml", "--rounds", "3", "--json",
                 "--no-progress", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    r = json.loads(run.stdout)
    first = r["chosen"][0]
    assert (first["kind"], first["col"], first["row"]) == ("state", 2, 0)
    assert first["F"] < np.exp(-0.1) and first["neg_log_F"] == pytest.approx(-np.log(first["F"]), rel=1e-9)
    ranking = pd.read_csv(tmp_path / "constraints_ranking.csv")
    round1 = ranking[ranking["round"] == 1]
    assert round1["F"].is_monotonic_increasing and round1["chosen"].sum() == 1
    assert no_temporaries(tmp_path)


def test_constraints_infer_on_the_example(tmp_path):
    run = mutual("constraints", "infer", EXAMPLES / "demonstrations.csv", "--world", EXAMPLES / "world.toml",
                 "--no-progress", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "round 1" in run.stdout and "Stopped:" in run.stdout
    assert {"constraints_ranking.csv", "constraints_chosen.csv", "constraints.png"} <= {p.name for p in
                                                                                        tmp_path.iterdir()}


@pytest.mark.parametrize("demos, world, phrases", [
    ("demonstrations_bad_action.csv", EXAMPLES / "world.toml",
     ["demonstrations_bad_action.csv", "column 'action'", "line 3", "'north'"]),
    (EXAMPLES / "demonstrations.csv", "world_bad_slip.toml", ["world_bad_slip.toml", "key 'slip'", "[0, 1]"]),
])
def test_constraints_infer_on_malformed_files(demos, world, phrases, tmp_path):
    run = mutual("constraints", "infer", MALFORMED / demos, "--world", MALFORMED / world, cwd=tmp_path)
    assert_one_line_error(run, *phrases)


SMALL_WORLD = 'width = 4\nheight = 3\nstart = [0, 0]\ngoal = [3, 0]\nslip = 0.1\n'
SMALL_DEMOS = "demo,t,state,action\n0,0,0,0\n0,1,1,0\n0,2,2,0\n0,3,3,\n"


CASES = [
    # ---- constraints infer
    ({"demos.csv": SMALL_DEMOS}, ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["w.toml: no such file"]),
    ({"demos.csv": SMALL_DEMOS, "w.toml": SMALL_WORLD.replace("slip = 0.1\n", "")},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["w.toml", "key 'slip': missing"]),
    ({"demos.csv": SMALL_DEMOS, "w.toml": SMALL_WORLD + "loiter = 'never'\n"},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["w.toml", "key 'loiter'"]),
    ({"demos.csv": SMALL_DEMOS.replace("state", "cell"), "w.toml": SMALL_WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["demos.csv", "missing column 'state'"]),
    ({"demos.csv": SMALL_DEMOS.replace("0,1,1,0", "0,1,1.5,0"), "w.toml": SMALL_WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["demos.csv", "column 'state'", "line 3",
                                                                   "'1.5' is not an integer"]),
    ({"demos.csv": SMALL_DEMOS.replace("0,1,1,0", "0,1,1,"), "w.toml": SMALL_WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["demos.csv", "column 'action'", "line 3"]),
    ({"demos.csv": SMALL_DEMOS.replace("0,1,1,0", "0,1,1,99"), "w.toml": SMALL_WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["demos.csv", "99"]),
    ({"demos.csv": SMALL_DEMOS.replace("0,2,2,0", "0,2,40,0"), "w.toml": SMALL_WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["demos.csv", "40"]),
    ({"demos.csv": SMALL_DEMOS.replace("0,2,2,0", "0,2,9,0"), "w.toml": SMALL_WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["demos.csv", "zero probability"]),
    ({"demos.csv": SMALL_DEMOS, "w.toml": SMALL_WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml", "--rounds", "0"], ["--rounds 0"]),
    ({"demos.csv": SMALL_DEMOS, "w.toml": SMALL_WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml", "--min-gain", "nan"], ["--min-gain nan"]),
    ({"demos.csv": SMALL_DEMOS, "w.toml": SMALL_WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml", "--min-gain", "-1"], ["--min-gain -1"]),
]


@pytest.mark.parametrize("files, argv, phrases", CASES, ids=[" ".join(c[1][:2]) + f" #{i}" for i, c in
                                                              enumerate(CASES)])
def test_bad_input_is_one_line_naming_what_is_wrong(files, argv, phrases, tmp_path):
    refuses_in_one_line(argv, files, phrases, tmp_path)
