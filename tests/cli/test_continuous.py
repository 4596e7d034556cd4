"""``mutual constraints infer-continuous`` and ``mutual constraints simulate`` end to end: through the real
console script on the pendulum example, and in-process on the car example, on a recording freshly
simulated by ``simulate`` (whose hidden limit inference must find), and on malformed input (exit 2, one line)."""

import json
from pathlib import Path

import pandas as pd
import pytest

from mutual.cli import continuous as cli_continuous
from mutual.cli import main

from helpers.cli import EXAMPLES, console
from helpers.continuous import planar_system

def double_integrator(low=-1.5, high=1.5, cells=15, dt=0.2, horizon=20, reward="", simulate=""):
    """A double-integrator system file heading for (1, 0) with the hidden wall velocity <= 0.5 in
    ``[simulate]``: the square box [low, high]^2 in ``cells`` x ``cells``, controls -1, 0, 1; ``reward``
    and ``simulate`` are extra lines of those tables."""
    return f"""\
system = "double_integrator"
[state]
low = [{low}, {low}]
high = [{high}, {high}]
cells = [{cells}, {cells}]
[control]
values = [-1.0, 0.0, 1.0]
[time]
dt = {dt}
horizon = {horizon}
[reward]
goal = [1.0, 0.0]
state_weights = [1.0, 0.1]
{reward}[simulate]
hidden = ["velocity <= 0.5"]
start = [-1.0, 0.0]
{simulate}"""


DOUBLE_INTEGRATOR = double_integrator(
    reward="control_weights = [0.05]\nterminal_weights = [5.0, 1.0]\ntemperature = 0.5\n",
    simulate="spread = [0.1, 0.0]\nn = 20\nfine_cells = [45, 45]\nrecord_every = 2\n")


def run_json(capsys, *argv):
    assert main([str(a) for a in argv] + ["--json", "--no-progress"]) == 0, capsys.readouterr().err
    return json.loads(capsys.readouterr().out)


def test_infer_continuous_on_the_pendulum_example_through_the_console_script(tmp_path):
    """The example's hidden limit is theta_dot <= 5 rad/s: the accepted constraint is that bound at the
    fastest recorded speed (the tightest bound the demonstrations satisfy), inside its likelihood interval."""
    run = console("constraints", "infer-continuous", EXAMPLES / "pendulum_trajectories.csv", "--system",
                  EXAMPLES / "pendulum.toml", "--json", "--out", tmp_path, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    first = out["chosen"][0]
    assert (first["name"], first["side"], first["units"]) == ("theta_dot", "upper", "rad/s")
    fastest = pd.read_csv(EXAMPLES / "pendulum_trajectories.csv")["theta_dot"].max()
    assert first["value"] == pytest.approx(fastest) and first["interval_low"] <= first["value"] <= first["interval_high"]
    assert first["gain_refit"] >= first["needed"] and out["controls_inferred"] == 0 and out["model"] == "points"
    for name in ("continuous_ranking.csv", "continuous_chosen.csv", "continuous_constraints.png"):
        assert (tmp_path / name).stat().st_size > 0
    ranking = pd.read_csv(tmp_path / "continuous_ranking.csv")
    assert {"round", "rank", "constraint", "gain", "gain_per_demo", "F", "needed", "accepted"} <= set(ranking.columns)


def test_infer_continuous_on_the_car_example_infers_its_controls(tmp_path, capsys):
    out = run_json(capsys, "constraints", "infer-continuous", EXAMPLES / "unicycle_trajectories.csv", "--system",
                   EXAMPLES / "unicycle.toml", "--cells", "13,10,8", "--rounds", "1", "--families", "disk",
                   "--out", tmp_path)
    assert out["controls_inferred"] == 20 * 28
    assert out["ranking"][0][0]["constraint"].startswith("disk at (x, y)")


@pytest.mark.parametrize("model", ["points", "cells"])
def test_simulate_then_infer_finds_the_hidden_limit_of_a_fresh_recording(tmp_path, capsys, model):
    (tmp_path / "di.toml").write_text(DOUBLE_INTEGRATOR)
    made = run_json(capsys, "constraints", "simulate", "--system", tmp_path / "di.toml", "--out", tmp_path / "sim")
    assert made["ranges"]["velocity"][1] <= 0.5 and made["period_seconds"] == pytest.approx(0.1)
    frame = pd.read_csv(tmp_path / "sim" / "trajectories.csv", dtype={"demo": str})
    assert list(frame.columns) == ["demo", "t", "position", "velocity", "acceleration"]
    out = run_json(capsys, "constraints", "infer-continuous", tmp_path / "sim" / "trajectories.csv", "--system",
                   tmp_path / "di.toml", "--model", model, *(["--inline"] if model == "cells" else []),
                   "--out", tmp_path / "inferred")
    first = out["chosen"][0]
    assert first["constraint"].startswith("velocity <=") and abs(first["value"] - 0.5) <= 0.2 + 1e-9
    assert out["n_demonstrations"] == 20 and out["steps"] == 20


#: a demonstrator that backs over the box's edge at -2
LEAVES_THE_BOX = dict(low=-2.0, high=2.0, cells=21, dt=0.1, horizon=30, simulate="n = 15\n")


def test_simulate_refuses_demonstrations_that_leave_the_box_before_writing(tmp_path, capsys):
    """A demonstrator that backs over the box's edge (position -2.01 of [-2, 2]) would write a file that
    infer-continuous refuses: simulate says so, names the coordinate, and writes nothing."""
    (tmp_path / "di.toml").write_text(double_integrator(**LEAVES_THE_BOX))
    assert main(["constraints", "simulate", "--system", str(tmp_path / "di.toml"), "--out", str(tmp_path / "sim"),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "leave the box" in err and "'position' reaches -2.01" in err and "widen [state] low/high" in err
    assert not (tmp_path / "sim").exists()
    (tmp_path / "wide.toml").write_text(double_integrator(**{**LEAVES_THE_BOX, "low": -2.5}))
    run_json(capsys, "constraints", "simulate", "--system", tmp_path / "wide.toml", "--out", tmp_path / "sim")
    out = run_json(capsys, "constraints", "infer-continuous", tmp_path / "sim" / "trajectories.csv", "--system",
                   tmp_path / "wide.toml", "--rounds", "1", "--out", tmp_path / "inferred")
    assert out["n_demonstrations"] == 15


def test_simulate_can_leave_the_controls_out(tmp_path, capsys):
    (tmp_path / "di.toml").write_text(DOUBLE_INTEGRATOR)
    made = run_json(capsys, "constraints", "simulate", "--system", tmp_path / "di.toml", "--n", "3", "--no-controls",
                    "--demonstrator", "mppi", "--out", tmp_path)
    assert not made["controls_written"] and made["demonstrator"] == "mppi"
    assert "acceleration" not in pd.read_csv(tmp_path / "trajectories.csv").columns


def test_simulate_a_gridworld_writes_demonstrations_that_infer_reads(tmp_path, capsys):
    made = run_json(capsys, "constraints", "simulate", "--world", EXAMPLES / "world.toml", "--hidden",
                    "cell 4 0 psi 0.25", "--hidden", "action NW", "--n", "10", "--seed", "3", "--out", tmp_path)
    assert made["n_demonstrations"] == 10
    assert list(pd.read_csv(tmp_path / "demonstrations.csv").columns) == ["demo", "t", "state", "action"]
    out = run_json(capsys, "constraints", "infer", tmp_path / "demonstrations.csv", "--world", EXAMPLES / "world.toml",
                   "--rounds", "1", "--out", tmp_path)
    assert out["n_demonstrations"] == 10


def test_simulate_that_fails_while_writing_leaves_no_output(tmp_path, capsys, monkeypatch):
    """The demonstrations go through the output set: a full disk after a partial write leaves nothing."""
    import errno
    import mutual.constraints as constraints

    def full_disk(path, demos):
        Path(path).write_text("demo,t,state,action\n0,0,")
        raise OSError(errno.ENOSPC, "No space left on device", str(path))
    monkeypatch.setattr(constraints, "write_demonstrations", full_disk)
    out = tmp_path / "sim"
    assert main(["constraints", "simulate", "--world", str(EXAMPLES / "world.toml"), "--n", "3", "--out", str(out),
                 "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert "No space left on device" in err and "no output was left" in err and "--out" in err
    assert not out.exists() and not list(tmp_path.iterdir())


@pytest.mark.parametrize("args, phrases", [
    (["infer-continuous", EXAMPLES / "malformed" / "trajectories_gap.csv", "--system", EXAMPLES / "pendulum.toml"],
     ["trajectories_gap.csv", "line 5", "column 't'", "gap in time"]),
    (["infer-continuous", EXAMPLES / "pendulum_trajectories.csv", "--system",
      EXAMPLES / "malformed" / "pendulum_bad_cells.toml"], ["pendulum_bad_cells.toml", "key 'state.cells'"]),
    (["infer-continuous", EXAMPLES / "pendulum_trajectories.csv", "--system", EXAMPLES / "unicycle.toml"],
     ["pendulum_trajectories.csv", "line 1", "missing column 'x'"]),
    (["infer-continuous", EXAMPLES / "pendulum_trajectories.csv", "--system", EXAMPLES / "pendulum.toml",
      "--cells", "41,x"], ["--cells 41,x"]),
    (["infer-continuous", EXAMPLES / "pendulum_trajectories.csv", "--system", EXAMPLES / "pendulum.toml",
      "--families", "blob"], ["--families blob", "unknown family 'blob'"]),
    (["infer-continuous", EXAMPLES / "pendulum_trajectories.csv", "--system", EXAMPLES / "pendulum.toml",
      "--families", "bound,cell"], ["--families", "'cell' candidates need --model cells"]),
    (["infer-continuous", EXAMPLES / "pendulum_trajectories.csv", "--system", EXAMPLES / "pendulum.toml",
      "--temperature", "-1"], ["--temperature -1", "'fit', 'file' or a positive number"]),
    (["infer-continuous", EXAMPLES / "pendulum_trajectories.csv", "--system", EXAMPLES / "pendulum.toml",
      "--temperature", "warm"], ["--temperature warm"]),
    (["infer-continuous", EXAMPLES / "pendulum_trajectories.csv", "--system", EXAMPLES / "pendulum.toml",
      "--model", "cells", "--temperature", "2"], ["--temperature", "--model points"]),
    (["infer-continuous", EXAMPLES / "pendulum_trajectories.csv", "--system", EXAMPLES / "pendulum.toml",
      "--min-gain", "-1"], ["--min-gain -1"]),
    (["simulate", "--system", EXAMPLES / "pendulum.toml", "--hidden", "omega < 3"], ["--hidden", "'omega'"]),
    (["simulate", "--world", EXAMPLES / "world.toml", "--hidden", "cell 99 0"], ["--hidden 'cell 99 0'"]),
])
def test_bad_input_is_one_line_naming_the_file_and_place(tmp_path, capsys, args, phrases):
    assert main(["constraints", *[str(a) for a in args], "--out", str(tmp_path)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and ": error: " in lines[0], lines
    for phrase in phrases:
        assert phrase in lines[0], lines[0]


def test_help_names_the_formats(capsys):
    for argv, phrase in ((["constraints", "infer-continuous", "--help"], "TRAJ.csv"),
                         (["constraints", "simulate", "--help"], "--hidden")):
        with pytest.raises(SystemExit):
            main(argv)
        assert phrase in capsys.readouterr().out


def test_the_command_line_spells_out_the_candidate_families_and_defaults():
    from mutual.constraints.continuous import inference
    from mutual.constraints.continuous.candidates import FAMILIES
    assert cli_continuous.FAMILIES == FAMILIES and set(inference.FAMILIES) == set(FAMILIES) - {"cell"}
    assert cli_continuous.MIN_GAIN["points"] == round(inference.MIN_GAIN, 3)


def test_the_cli_runs_a_two_dimensional_control_end_to_end(tmp_path, capsys):
    """simulate writes both control columns; infer-continuous reads them back and snaps every recorded step to
    a control of the 2-D set (the demonstrator used only controls of the set: each snaps to itself)."""
    path = planar_system(tmp_path)
    assert main(["constraints", "simulate", "--system", str(path), "--out", str(tmp_path / "sim"),
                 "--no-progress", "--json"]) == 0
    simulated = json.loads(capsys.readouterr().out)
    assert simulated["dynamics_file"] == str((tmp_path / "planar.py").resolve())
    table = pd.read_csv(tmp_path / "sim" / "trajectories.csv")
    assert {"vx", "vy"} <= set(table.columns) and (table["y"] <= 1.4 + 1e-9).all()
    recorded = table[["vx", "vy"]].dropna().to_numpy()
    assert {tuple(u) for u in recorded} <= {(1.0, 0.0), (0.0, 1.0), (0.0, -1.0), (-1.0, 0.0), (0.0, 0.0)}
    assert main(["constraints", "infer-continuous", str(tmp_path / "sim" / "trajectories.csv"), "--system", str(path),
                 "--model", "cells", "--inline", "--rounds", "1", "--out", str(tmp_path / "inf"), "--no-progress",
                 "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["controls"]["recorded_snapped"] == 6 * 12 and result["n_controls"] == 5
    assert main(["constraints", "infer-continuous", str(tmp_path / "sim" / "trajectories.csv"), "--system", str(path),
                 "--rounds", "1", "--out", str(tmp_path / "points"), "--no-progress", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)                       # the default points model uses them as recorded
    assert result["model"] == "points" and result["n_controls"] == 5 and result["controls_inferred"] == 0


def test_the_cli_names_the_system_file_for_a_failure_inside_the_dynamics(tmp_path, capsys):
    trajectories = tmp_path / "t.csv"
    trajectories.write_text("demo,t,x,y\na,0,0.25,1\na,0.25,0.5,1\n" + "".join(
        f"a,{0.25 * k:g},{min(0.25 * (k + 1), 2.95):g},1\n" for k in range(2, 13)))
    path = planar_system(tmp_path, "fails_later:f")
    status = main(["constraints", "infer-continuous", str(trajectories), "--system", str(path), "--inline",
                   "--rounds", "1", "--out", str(tmp_path / "o"), "--no-progress"])
    err = capsys.readouterr().err                       # (after a warning: the recording rides the box's edge)
    assert status == 2 and f"mutual constraints infer-continuous: error: {path}: key 'system': " in err
    assert "fails_later.py" in err and "raised ArithmeticError: left the table at line 4 of" in err


def test_the_cli_refuses_a_hidden_region_given_on_the_command_line_around_the_start(tmp_path, capsys):
    path = planar_system(tmp_path)
    status = main(["constraints", "simulate", "--system", str(path), "--hidden", "x <= 0.1", "--out",
                   str(tmp_path / "o"), "--no-progress"])
    assert status == 2 and "lies inside the hidden region 'x <= 0.1'" in capsys.readouterr().err
