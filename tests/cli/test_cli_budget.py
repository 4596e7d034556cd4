"""Requests beyond the machine, refused by every ``mutual`` command before the work starts (``mutual.budget``):
exit status 2 and one line with the estimate (memory, time), the knob to turn and ``--allow-large``; a
figure that would be unreadable left out with the tables written; no MemoryError traceback ever."""

import math
import re
from pathlib import Path

import numpy as np
import pytest

from mutual.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "data" / "examples"
PENDULUM = (EXAMPLES / "pendulum.toml").read_text()
TRAJ = str(EXAMPLES / "pendulum_trajectories.csv")
INFER = ["constraints", "infer-continuous", TRAJ, "--system"]


def _replace(text, key, value):
    new, count = re.subn(rf"^{key} = .*$", f"{key} = {value}", text, count=1, flags=re.M)
    assert count == 1, key
    return new


def _levels_csv(levels, subjects=3):
    rng = np.random.default_rng(0)
    rows = [f"s{s},L{k:04d},{rng.normal():.6f}" for s in range(subjects) for k in range(levels)]
    return "subject,level,value\n" + "\n".join(rows) + "\n"


def _legible(distractors, steps):
    d = ", ".join(f"[{10 * math.cos(2 * math.pi * i / distractors):.5f}, "
                  f"{20 + 10 * math.sin(2 * math.pi * i / distractors):.5f}]" for i in range(distractors))
    return (f'dynamics = "single-integrator"\nstart = [0.0, 0.0]\ngoal = [4.0, 4.0]\ndistractors = [{d}]\n'
            f"horizon = 1.0\nsteps = {steps}\nalpha = 1.0\n")


WORLD = "width = 40\nheight = 40\nstart = [0, 0]\ngoal = [39, 0]\nslip = 0.1\nhorizon = 300\n"
ANOVA = ["study", "anova", "data.csv", "--dv", "value", "--within", "level", "--subject", "subject"]
W_MAX = ",".join(f"{0.25 + 0.005 * i:g}" for i in range(551))

# (files to write, argv, phrases of the one-line refusal)
CASES = [
    ({"data.csv": _levels_csv(1000)}, ANOVA, ["1,000 levels x 3 subjects", "499,500 pairs", "minutes", "--levels"]),
    ({"s.toml": PENDULUM}, INFER + ["s.toml", "--cells", "2000,2000"], ["2,000 x 2,000 cells", "GiB", "--cells"]),
    ({"s.toml": PENDULUM}, INFER + ["s.toml", "--cells", f"{10 ** 9},{10 ** 9}"],
     ["1,000,000,000 x 1,000,000,000 cells", "GiB"]),
    ({"s.toml": PENDULUM}, INFER + ["s.toml", "--cells", "1000,1000"], ["1,000 x 1,000 cells", "hours"]),
    ({"s.toml": PENDULUM}, INFER + ["s.toml", "--cells", "1000"], ["1,000 x 1,000 cells"]),
    ({"s.toml": (EXAMPLES / "cartpole.toml").read_text()}, INFER + ["s.toml", "--cells", "1000,1000,1000,1000"],
     ["1,000 x 1,000 x 1,000 x 1,000 cells", "GiB"]),
    ({"s.toml": _replace(PENDULUM, "cells", f"[{10 ** 9}, {10 ** 9}]")}, INFER + ["s.toml"],
     ["1,000,000,000 x 1,000,000,000 cells", "[state] cells"]),
    ({"s.toml": _replace(PENDULUM, "horizon", str(10 ** 7))}, INFER + ["s.toml"],
     ["10,000,000 steps", "[time] horizon", "days"]),
    ({"s.toml": _replace(PENDULUM, "samples", str(10 ** 9))}, INFER + ["s.toml"],
     ["1,000,000,000 samples", "GiB", "[discretization] samples"]),
    ({"s.toml": _replace(PENDULUM, "fine_cells", "[100000, 100000]")},
     ["constraints", "simulate", "--system", "s.toml"], ["100,000 x 100,000 cells", "[simulate] fine_cells"]),
    ({"s.toml": PENDULUM}, ["constraints", "simulate", "--system", "s.toml", "--n", str(10 ** 9)],
     ["1,000,000,000 demonstrations", "GiB", "--n"]),
    ({"s.toml": _replace(PENDULUM, "demonstrator", '"mppi"') + "samples = 10000000\n"},
     ["constraints", "simulate", "--system", "s.toml"], ["20 demonstrations of 60 steps", "days"]),
    ({"w.toml": WORLD, "d.csv": "demo,t,state,action\n"}, ["constraints", "infer", "d.csv", "--world", "w.toml"],
     ["1,600 states", "300 steps", "--rounds"]),
    ({"w.toml": WORLD.replace("40", "9").replace("39", "8")},
     ["constraints", "simulate", "--world", "w.toml", "--n", str(10 ** 12)], ["1,000,000,000,000 demonstrations"]),
    ({"l.toml": _legible(3000, 10_000)}, ["motion", "legible", "l.toml"], ["10,000 steps against 3,001 goals",
                                                                          "35 minutes", "fewer distractors"]),
    ({}, ["supervisor", "fit", str(EXAMPLES / "interventions.csv"), "--w-max", W_MAX],
     ["551 value functions on 101 x 101 x 64 nodes", "--w-max"]),
    ({}, ["study", "power", "--cohorts", "5000", "--n", "40"], ["5,000 simulated cohorts of 40", "--cohorts"]),
    ({}, ["supervisor", "fit", str(EXAMPLES / "interventions.csv"), "--w-max",
          ",".join(f"{0.01 * k:.2f}" for k in range(41, 241))],
     ["200 value functions on 101 x 101 x 64 nodes", "minutes", "--w-max", "--grid quick"]),
    ({}, ["study", "power", "--f", "0.25", "--n", "3:100000000"], ["99,999,998 sample sizes", "hours", "--n a:b:step"]),
]


@pytest.mark.parametrize("files, argv, phrases", CASES, ids=[" ".join(c[1][:2]) + f" {i}" for i, c in enumerate(CASES)])
def test_a_request_beyond_the_machine_is_refused_with_its_estimate(tmp_path, monkeypatch, capsys, files, argv, phrases):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MUTUAL_MAX_MINUTES", raising=False)
    for name, text in files.items():
        Path(name).write_text(text)
    status = main(argv + ["--out", "out", "--no-progress"])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1, err
    for phrase in phrases + ["about", "--allow-large"]:
        assert phrase in err[0], (phrase, err[0])
    assert not Path("out").exists()


def test_the_time_limit_is_stated_by_the_environment_and_the_flag_goes_ahead(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    Path("data.csv").write_text(_levels_csv(3, 4))
    monkeypatch.setenv("MUTUAL_MAX_MINUTES", "1e-9")
    assert main(ANOVA + ["--out", "refused"]) == 2
    assert "the limit is 1e-09 minutes" in capsys.readouterr().err
    assert main(ANOVA + ["--out", "allowed", "--allow-large"]) == 0
    assert sorted(p.name for p in Path("allowed").iterdir()) == ["anova_value.csv", "cells_value.csv",
                                                                  "means_value.png", "pairwise_value.csv"]
    monkeypatch.setenv("MUTUAL_MAX_MINUTES", "soon")
    assert main(ANOVA + ["--out", "bad"]) == 2
    assert "MUTUAL_MAX_MINUTES = 'soon'" in capsys.readouterr().err


def test_a_long_request_that_goes_ahead_says_its_estimate_first(tmp_path, monkeypatch, capsys):
    """A request let through but estimated above a minute is said on stderr before it starts (here the threshold is
    lowered to 0 s, so this small ANOVA is 'long'); one estimated below it is not; --allow-large past the limit too."""
    from mutual import budget
    monkeypatch.chdir(tmp_path)
    Path("data.csv").write_text(_levels_csv(3, 4))
    assert main(ANOVA + ["--out", "quiet"]) == 0
    assert "estimated before starting" not in capsys.readouterr().err
    monkeypatch.setattr(budget, "NOTICE_SECONDS", 0.0)
    assert main(ANOVA + ["--out", "said"]) == 0
    said = [line for line in capsys.readouterr().err.splitlines() if "3 levels x 4 subjects" in line]
    assert len(said) == 1 and said[0].startswith("mutual study anova: ") and "estimated before starting" in said[0]
    assert "the limit is 30 minutes" in said[0] and "are available" in said[0], said
    monkeypatch.setenv("MUTUAL_MAX_MINUTES", "1e-9")
    assert main(ANOVA + ["--out", "allowed", "--allow-large"]) == 0
    assert "the limit is 1e-09 minutes" in capsys.readouterr().err


def test_too_many_levels_to_draw_write_the_tables_and_say_so(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    Path("data.csv").write_text(_levels_csv(31))
    assert main(ANOVA + ["--out", "out", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "no figure: 31 levels" in out and "the first 45 of 465 pairs" in out
    assert sorted(p.name for p in Path("out").iterdir()) == ["anova_value.csv", "cells_value.csv", "pairwise_value.csv"]
    assert len(Path("out/pairwise_value.csv").read_text().splitlines()) == 1 + 465


def test_running_out_of_memory_is_one_line_never_a_traceback(tmp_path, monkeypatch, capsys):
    import mutual.cli.study as study

    def exhausted(*args, **kwargs):
        raise MemoryError("Unable to allocate 7.45 GiB for an array with shape (1000000001,)")

    monkeypatch.chdir(tmp_path)
    Path("data.csv").write_text(_levels_csv(3, 4))
    monkeypatch.setattr(study, "analyse", exhausted)
    assert main(ANOVA + ["--out", "out"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "ran out of memory" in err[0] and "7.45 GiB" in err[0] and "Traceback" not in err[0]


def _study_csv(subjects, levels, value, extra_columns=0):
    extra = "".join(f",x{k}" for k in range(extra_columns))
    zeros = ",0" * extra_columns
    rows = "".join(f"s{i},L{j:02d},{value(i, j)}{zeros}\n" for i in range(subjects) for j in range(levels))
    return f"subject,level,value{extra}\n" + rows


# (subjects, levels, value(i, j), extra columns, phrases of the summary, files written)
STUDIES = [
    (3, 50, lambda i, j: (i * 13 + j * 7) % 11 + i, 0,
     ["no paired t-test for 568 of 1,225 pairs", "Holm over the other 657", "Tukey's q is defined for every pair",
      "'L00' and 'L02': the paired differences are the same for every subject (-3)", "no figure: 50 levels"],
     ["anova_value.csv", "cells_value.csv", "pairwise_value.csv"]),
    (20_000, 2, lambda i, j: (i * 7919 + j * 104729) % 1000, 0, ["20000 subjects"],
     ["anova_value.csv", "cells_value.csv", "means_value.png", "pairwise_value.csv"]),
    (6, 3, lambda i, j: (i * 7 + j * 3) % 5 + 2 * j + 1, 100_000, ["6 subjects"],
     ["anova_value.csv", "cells_value.csv", "means_value.png", "pairwise_value.csv"]),
]


@pytest.mark.parametrize("subjects, levels, value, extra, phrases, written", STUDIES)
def test_large_valid_studies_are_analysed_in_seconds(tmp_path, monkeypatch, capsys, subjects, levels, value, extra,
                                                     phrases, written):
    """Many subjects (drawn without their lines), many columns (never made into a table), constant paired
    differences (that pair untested, said so): the tables are written."""
    monkeypatch.chdir(tmp_path)
    Path("data.csv").write_text(_study_csv(subjects, levels, value, extra))
    assert main(ANOVA + ["--out", "out", "--no-progress"]) == 0
    out = capsys.readouterr().out
    for phrase in phrases:
        assert phrase in out, (phrase, out[-600:])
    assert sorted(p.name for p in Path("out").iterdir()) == written


def test_the_estimate_of_an_anova_counts_its_rows(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    Path("data.csv").write_text(_study_csv(2_000, 2, lambda i, j: i + j * j))
    monkeypatch.setenv("MUTUAL_MAX_MINUTES", "5e-4")
    assert main(ANOVA + ["--out", "out", "--no-progress"]) == 2
    err = capsys.readouterr().err
    for phrase in ("2 levels x 2,000 subjects", "4,000 rows", "the limit is 0.0005 minutes", "--allow-large"):
        assert phrase in err, (phrase, err)
