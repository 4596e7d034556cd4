"""``mutual motion legible`` end to end: on a fresh spec against the closed form, on the example, and on
malformed or unsolvable specs (exit 2, one line naming the file and the key; a table); it never prints
null evidence."""

import json

import numpy as np
import pandas as pd
import pytest

from mutual.cli import main

from helpers.cli import EXAMPLES, MALFORMED, assert_one_line_error, mutual, refuses_in_one_line


def test_motion_legible_on_a_fresh_spec_matches_the_closed_form(tmp_path):
    # goals (-1, 1) and (1, 1), dt = 0.01, N = 100, alpha = 1: the legible optimum applies the constant
    # control u = (1.5, 0.5) and ends at (1.5, 0.5); the predictable optimum ends at (0.5, 0.5)
    (tmp_path / "spec.toml").write_text('start = [0, 0]\ngoal = [1, 1]\ndistractors = [[-1, 1]]\n'
                                        'horizon = 1.0\nsteps = 100\nalpha = 1.0\n')
    run = mutual("motion", "legible", "spec.toml", "--json", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    r = json.loads(run.stdout)
    assert r["final_position"] == pytest.approx([1.5, 0.5], abs=1e-9)
    assert r["predictable_final_position"] == pytest.approx([0.5, 0.5], abs=1e-9)
    assert r["evidence"]["legible"][0] < r["evidence"]["predictable"][0] < 0
    table = pd.read_csv(tmp_path / "legible_trajectory.csv")
    assert len(table) == 101 and np.allclose(table[["u_x", "u_y"]].iloc[:-1], [1.5, 0.5], atol=1e-9)
    assert table[["u_x", "u_y"]].iloc[-1].isna().all()


def test_motion_legible_on_the_example(tmp_path):
    run = mutual("motion", "legible", EXAMPLES / "legible.toml", "--out", tmp_path / "o", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "log Lambda" in run.stdout
    assert {p.name for p in (tmp_path / "o").iterdir()} == {"legible_trajectory.csv", "legible_trajectory.png"}


def test_motion_legible_on_a_malformed_spec(tmp_path):
    assert_one_line_error(mutual("motion", "legible", MALFORMED / "legible_bad_alpha.toml", cwd=tmp_path),
                          "legible_bad_alpha.toml", "key 'alpha'", "positive")


SPEC = 'start = [0, 0]\ngoal = [1, 1]\ndistractors = [[-1, 1]]\nhorizon = 1.0\nsteps = 10\nalpha = 1.0\n'


CASES = [
    # ---- motion legible
    ({}, ["motion", "legible", "spec.toml"], ["spec.toml: no such file"]),
    ({"spec.toml": "start = [0, 0\n"}, ["motion", "legible", "spec.toml"], ["spec.toml", "not valid TOML"]),
    ({"spec.toml": SPEC + "colour = 1\n"}, ["motion", "legible", "spec.toml"], ["spec.toml", "key 'colour'"]),
    ({"spec.toml": SPEC.replace("goal = [1, 1]\n", "")}, ["motion", "legible", "spec.toml"],
     ["spec.toml", "key 'goal': missing"]),
    ({"spec.toml": 'dynamics = "dubins"\n' + SPEC}, ["motion", "legible", "spec.toml"],
     ["spec.toml", "key 'start': must be a list of 3 numbers"]),
    ({"spec.toml": SPEC.replace("steps = 10", "steps = 0")}, ["motion", "legible", "spec.toml"],
     ["spec.toml", "key 'steps'"]),
    ({"spec": {}}, ["motion", "legible", "spec"], ["spec: not a file"]),
]


@pytest.mark.parametrize("files, argv, phrases", CASES, ids=[" ".join(c[1][:2]) + f" #{i}" for i, c in
                                                              enumerate(CASES)])
def test_bad_input_is_one_line_naming_what_is_wrong(files, argv, phrases, tmp_path):
    refuses_in_one_line(argv, files, phrases, tmp_path)


# ---- the command line: one line, exit 2, never null ---------------------------------------------------
TOML = 'start = [0, 0]\ngoal = [1, 1]\ndistractors = [[-1, 1]]\nhorizon = 1.0\nsteps = 10\nalpha = 1.0\n'


CLI = [
    (TOML.replace("start = [0, 0]", "start = [1e300, 0]"), "key 'start'"),
    (TOML.replace("alpha = 1.0", "alpha = nan"), "key 'alpha'"),
    (TOML.replace("horizon = 1.0", "horizon = " + "1" * 400), "key 'horizon'"),
    (TOML.replace("steps = 10", "steps = 100000000"), "GiB"),
    (TOML.replace("alpha = 1.0", "eta = -100.0").replace("goal = [1, 1]", "goal = [0, 1]")
     .replace("[[-1, 1]]", "[[-1, 1], [1, 1]]"), "key 'eta'"),
]


@pytest.mark.parametrize("text, phrase", CLI, ids=["start 1e300", "alpha nan", "huge horizon", "steps 1e8", "eta"])
def test_the_command_refuses_in_one_line(text, phrase, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "spec.toml").write_text(text)
    status = main(["motion", "legible", "spec.toml", "--json", "--no-progress", "--out", "o"])
    captured = capsys.readouterr()
    assert status == 2 and len(captured.err.strip().splitlines()) == 1 and phrase in captured.err
    assert captured.out == "" and not (tmp_path / "o").exists()


def test_the_command_never_prints_null_evidence(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "spec.toml").write_text(TOML.replace("[1, 1]", "[1e-300, 1e-300]").replace("[[-1, 1]]",
                                                                                           "[[-1e-300, 1e-300]]"))
    assert main(["motion", "legible", "spec.toml", "--json", "--no-progress", "--out", "o"]) == 0
    results = json.loads(capsys.readouterr().out)
    assert None not in results["evidence"]["legible"] + results["evidence"]["predictable"]
