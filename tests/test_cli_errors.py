"""Bad input to the ``mutual`` commands, table-driven and in-process (``mutual.cli.main``): each case
exits with status 2 and one line on stderr that names the file (or option) and the column, line or
key at fault, never a traceback, and writes no output file."""

from pathlib import Path

import pytest

from mutual.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "data" / "examples"
STUDY = "who,cond,y\ns1,a,1\ns1,b,2\ns2,a,2\ns2,b,4\ns3,a,3\ns3,b,3.5\n"
SPEC = 'start = [0, 0]\ngoal = [1, 1]\ndistractors = [[-1, 1]]\nhorizon = 1.0\nsteps = 10\nalpha = 1.0\n'
WORLD = 'width = 4\nheight = 3\nstart = [0, 0]\ngoal = [3, 0]\nslip = 0.1\n'
DEMOS = "demo,t,state,action\n0,0,0,0\n0,1,1,0\n0,2,2,0\n0,3,3,\n"
INTERVENTIONS = (EXAMPLES / "interventions.csv").read_text() if (EXAMPLES / "interventions.csv").exists() else ""
ANOVA = ["study", "anova", "data.csv", "--dv", "y", "--within", "cond", "--subject", "who"]

# (files to write {name: text or bytes}, argv, phrases the one-line message must contain)
CASES = [
    # ---- study anova
    ({}, ANOVA, ["data.csv: no such file"]),
    ({"data.csv": ""}, ANOVA, ["data.csv", "the file is empty"]),
    ({"data.csv": "who,cond,y\n"}, ANOVA, ["data.csv", "no data rows"]),
    ({"data.csv": b"\xff\xfe\x00w\x00h\x00o"}, ANOVA, ["data.csv"]),
    ({"data.csv": STUDY.replace("y\n", "score\n", 1)}, ANOVA, ["data.csv", "missing column 'y'"]),
    ({"data.csv": STUDY.replace("s2,b,4", "s2,b,four")}, ANOVA, ["data.csv", "column 'y'", "line 5", "'four'"]),
    ({"data.csv": STUDY.replace("s2,b,4", "s2,b,")}, ANOVA, ["column 'y'", "line 5", "empty"]),
    ({"data.csv": STUDY.replace("s3,a,3", ",a,3")}, ANOVA, ["column 'who'", "line 6", "empty"]),
    ({"data.csv": STUDY + "s3,b,4\n"}, ANOVA, ["data.csv", "('s3', 'b')", "--aggregate mean"]),
    ({"data.csv": STUDY.replace("s3,b,3.5\n", "")}, ANOVA, ["data.csv", "unbalanced design", "s3"]),
    ({"data.csv": "who,cond,y\ns1,a,1\ns2,a,2\n"}, ANOVA, ["data.csv", "at least 2"]),
    ({"data.csv": "who,cond,y\ns1,a,1\ns1,b,1\ns2,a,1\ns2,b,1\ns3,a,1\ns3,b,1\n"}, ANOVA,
     ["data.csv", "'y' does not vary"]),
    ({"data.csv": STUDY}, ANOVA + ["--where", "cond"], ["--where 'cond'", "COL=VALUE"]),
    ({"data.csv": STUDY}, ANOVA + ["--where", "cond=z"], ["data.csv", "no row has cond = 'z'"]),
    ({"data.csv": STUDY}, ANOVA + ["--where", "phase=2"], ["data.csv", "missing column 'phase'"]),
    ({"data.csv": STUDY}, ANOVA + ["--levels", "a,c"], ["data.csv", "--levels", "no row has cond = 'c'"]),
    ({"data.csv": STUDY}, ANOVA + ["--levels", "a"], ["data.csv", "at least 2"]),
    ({"data.csv": STUDY, "taken": "a file"}, ANOVA + ["--out", "taken"], ["--out taken", "not a folder"]),
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
    # ---- constraints infer
    ({"demos.csv": DEMOS}, ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["w.toml: no such file"]),
    ({"demos.csv": DEMOS, "w.toml": WORLD.replace("slip = 0.1\n", "")},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["w.toml", "key 'slip': missing"]),
    ({"demos.csv": DEMOS, "w.toml": WORLD + "loiter = 'never'\n"},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["w.toml", "key 'loiter'"]),
    ({"demos.csv": DEMOS.replace("state", "cell"), "w.toml": WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["demos.csv", "missing column 'state'"]),
    ({"demos.csv": DEMOS.replace("0,1,1,0", "0,1,1.5,0"), "w.toml": WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["demos.csv", "column 'state'", "line 3",
                                                                   "'1.5' is not an integer"]),
    ({"demos.csv": DEMOS.replace("0,1,1,0", "0,1,1,"), "w.toml": WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["demos.csv", "column 'action'", "line 3"]),
    ({"demos.csv": DEMOS.replace("0,1,1,0", "0,1,1,99"), "w.toml": WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["demos.csv", "99"]),
    ({"demos.csv": DEMOS.replace("0,2,2,0", "0,2,40,0"), "w.toml": WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["demos.csv", "40"]),
    ({"demos.csv": DEMOS.replace("0,2,2,0", "0,2,9,0"), "w.toml": WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml"], ["demos.csv", "zero probability"]),
    ({"demos.csv": DEMOS, "w.toml": WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml", "--rounds", "0"], ["--rounds 0"]),
    ({"demos.csv": DEMOS, "w.toml": WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml", "--min-gain", "nan"], ["--min-gain nan"]),
    ({"demos.csv": DEMOS, "w.toml": WORLD},
     ["constraints", "infer", "demos.csv", "--world", "w.toml", "--min-gain", "-1"], ["--min-gain -1"]),
    # ---- supervisor fit (all refused before any value function is computed)
    ({}, ["supervisor", "fit", "i.csv"], ["i.csv: no such file"]),
    ({"i.csv": INTERVENTIONS.replace("theta", "heading", 1)}, ["supervisor", "fit", "i.csv"],
     ["i.csv", "missing column 'theta'"]),
    ({"i.csv": INTERVENTIONS.replace("sim-02,0,", "sim-02,0.5,", 1)}, ["supervisor", "fit", "i.csv"],
     ["i.csv", "column 'trial'", "0.5"]),
    ({"i.csv": INTERVENTIONS.replace("sim-03,", ",", 1)}, ["supervisor", "fit", "i.csv"],
     ["i.csv", "column 'participant'", "empty"]),
    ({"i.csv": INTERVENTIONS + "sim-04,1,-2,1,1,0,0,0\n"}, ["supervisor", "fit", "i.csv"],
     ["i.csv", "line 92", "column 'time'", "negative"]),
    ({"i.csv": INTERVENTIONS + "sim-04,1,2,1,1,0,0,0,9\n"}, ["supervisor", "fit", "i.csv"], ["i.csv"]),
    ({"i.csv": INTERVENTIONS}, ["supervisor", "fit", "i.csv", "--participant", "nobody"],
     ["i.csv", "no intervention of participant 'nobody'"]),
    ({"i.csv": INTERVENTIONS}, ["supervisor", "fit", "i.csv", "--pool", "--participant", "sim-01"],
     ["--pool and --participant"]),
    ({"i.csv": INTERVENTIONS}, ["supervisor", "fit", "i.csv", "--w-max", "0.5,fast"], ["--w-max '0.5,fast'"]),
    ({"i.csv": INTERVENTIONS}, ["supervisor", "fit", "i.csv", "--w-max", "1"], ["--w-max '1'", "two members"]),
    ({"i.csv": INTERVENTIONS}, ["supervisor", "fit", "i.csv", "--level", "inf"], ["--level inf"]),
]


@pytest.mark.parametrize("files, argv, phrases", CASES, ids=[" ".join(c[1][:2]) + f" #{i}" for i, c in
                                                              enumerate(CASES)])
def test_bad_input_is_one_line_naming_what_is_wrong(files, argv, phrases, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    for name, content in files.items():
        if isinstance(content, dict):
            (tmp_path / name).mkdir()
        elif isinstance(content, bytes):
            (tmp_path / name).write_bytes(content)
        else:
            (tmp_path / name).write_text(content)
    before = set(tmp_path.iterdir())
    status = main(argv + ["--no-progress"])
    err = capsys.readouterr().err.strip()
    assert status == 2, err
    assert len(err.splitlines()) == 1 and err.startswith("mutual ") and ": error: " in err, err
    for phrase in phrases:
        assert phrase in err, err
    assert set(tmp_path.iterdir()) == before, "nothing is written on bad input"


def test_an_unexpected_failure_is_one_line_with_status_1(tmp_path, monkeypatch, capsys):
    from mutual.cli import motion
    monkeypatch.chdir(tmp_path)
    (tmp_path / "spec.toml").write_text(SPEC)

    def broken(spec):
        raise RuntimeError("solver exploded\nsecond line")
    monkeypatch.setattr("mutual.motion.spec.solve_legible", broken)
    monkeypatch.delenv("MUTUAL_DEBUG", raising=False)
    assert motion.run_legible.__module__ == "mutual.cli.motion"
    assert main(["motion", "legible", "spec.toml", "--no-progress"]) == 1
    err = capsys.readouterr().err.strip()
    assert err == ("mutual motion legible: error: RuntimeError: solver exploded second line "
                   "(set MUTUAL_DEBUG=1 for the traceback)")
    monkeypatch.setenv("MUTUAL_DEBUG", "1")
    with pytest.raises(RuntimeError):
        main(["motion", "legible", "spec.toml", "--no-progress"])


def test_json_output_is_one_object_with_nan_as_null(tmp_path, monkeypatch, capsys):
    import json
    monkeypatch.chdir(tmp_path)
    (tmp_path / "spec.toml").write_text(SPEC)
    assert main(["motion", "legible", "spec.toml", "--json", "--no-progress"]) == 0
    out = capsys.readouterr().out
    r = json.loads(out)
    assert r["command"] == "motion legible" and r["eta"] is None and r["duals"] is None
    assert sorted(p.name for p in tmp_path.iterdir()) == ["legible_trajectory.csv", "legible_trajectory.png",
                                                         "spec.toml"]
