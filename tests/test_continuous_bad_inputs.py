"""Bad input to continuous constraint inference (issue 21) gets a clear error naming the argument, the
file, the line and the column or key -- never a deep numpy traceback or a silent nan."""

import textwrap

import numpy as np
import pytest

from mutual.constraints.continuous import (Grid, Problem, QuadraticReward, discretize, integrate, load_system,
                                           named_system, parse_region, read_recording, system_from_mapping)
from mutual.constraints.continuous.mapping import check_recording
from mutual.constraints.continuous.systems import System

PENDULUM_CSV = "demo,t,theta,theta_dot,torque\n"


def pendulum_problem(cells=(9, 9)):
    system = named_system("pendulum")
    grid = Grid.uniform([-np.pi, -8.0], [np.pi, 8.0], cells, [True, False], system.state_names, system.state_units)
    return Problem(system, grid, [-3.0, 0.0, 3.0], 0.1, 10, QuadraticReward([np.pi, 0], [1, 0.1], [0.0], [1, 1]))


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def read(path):
    return read_recording(path, ("theta", "theta_dot"), ("torque",))


def test_non_finite_dynamics_output_names_the_system_the_state_and_the_control(tmp_path, monkeypatch):
    write(tmp_path, "blowup.py", """
        import numpy as np
        def f(x, u, k=1.0):
            return np.stack([x[:, 1], np.where(x[:, 0] > 0.5, np.inf, -k * x[:, 0] + u[:, 0])], axis=1)
        """)
    system = System("blowup:f", ("q", "p"), ("m", "m/s"), ("u",), ("N",), folder=str(tmp_path))
    with pytest.raises(ValueError, match=r"system 'blowup:f': the dynamics gave a non-finite state .* x = \[0\.6"):
        integrate(system, np.array([[0.1, 0.0], [0.6, 0.0]]), np.array([0.0]), 0.1)
    grid = Grid.uniform([-1, -1], [1, 1], [5, 5], [False, False], ("q", "p"), ("m", "m/s"))
    problem = Problem(system, grid, [0.0], 0.1, 3, QuadraticReward([0, 0], [1, 1], [0], [0, 0]))
    with pytest.raises(ValueError, match="non-finite"):
        discretize(problem, scheduler="inline")


@pytest.mark.parametrize("spec, parameters, phrase", [
    ("nosuchmodule:f", {}, "cannot import module 'nosuchmodule'"),
    ("math:nosuch", {}, "module 'math' has no function 'nosuch'"),
    ("rocket", {}, "neither a named system"),
    ("pendulum", {"mass": "heavy"}, "'mass' must be a finite number"),
    ("pendulum", {"inertia": 1.0}, "takes no parameter 'inertia'"),
])
def test_a_bad_dynamics_spec_is_refused(spec, parameters, phrase):
    with pytest.raises(ValueError, match=phrase):
        System(spec, ("a", "b"), ("", ""), ("u",), ("",), parameters=parameters)


def test_a_box_that_excludes_the_demonstrations_names_file_line_and_column(tmp_path):
    path = write(tmp_path, "t.csv", PENDULUM_CSV + "a,0,0,0,3\na,0.1,0.1,9.5,3\na,0.2,0.2,2,\n")
    with pytest.raises(ValueError, match=r"t\.csv, line 3, column 'theta_dot': 9\.5 is outside the box \[-8, 8\]"):
        check_recording(pendulum_problem(), read(path))


def test_angles_outside_their_range_wrap_instead(tmp_path):
    path = write(tmp_path, "t.csv", PENDULUM_CSV + "a,0,7.0,0,3\na,0.1,7.1,1,3\n")
    check_recording(pendulum_problem(), read(path))


@pytest.mark.parametrize("rows, phrase", [
    ("a,0,0,0,3\na,0.1,0,0,3\na,0.3,0,0,3\n", r"line 4, column 't': time jumps from 0\.1 to 0\.3 s .*a gap in time"),
    ("a,0,0,0,3\na,0.1,0,0,3\na,0.1,0,0,3\n", r"line 4, column 't': time 0\.1 repeats"),
    ("a,0,0,0,3\na,0.03,0,0,3\na,0.06,0,0,3\n", "does not divide the model's time step dt = 0.1"),
    ("a,0,0,0,3\na,0.1,0,0,3\nb,0,0,0,3\nb,0.1,0,0,3\nb,0.2,0,0,3\n", "spans 2 steps .* must span the same time"),
])
def test_bad_timing_names_the_line(tmp_path, rows, phrase):
    path = write(tmp_path, "t.csv", PENDULUM_CSV + rows)
    with pytest.raises(ValueError, match=phrase):
        check_recording(pendulum_problem(), read(path))


def test_unequal_durations_can_be_truncated(tmp_path):
    path = write(tmp_path, "t.csv", PENDULUM_CSV + "a,0,0,0,3\na,0.1,0,0,3\nb,0,0,0,3\nb,0.1,0,0,3\nb,0.2,0,0,3\n")
    check_recording(pendulum_problem(), read(path), truncate=True)


@pytest.mark.parametrize("text, phrase", [
    ("", "the file is empty"),
    ("demo,t,theta\n", "line 1: missing column 'theta_dot'"),
    (PENDULUM_CSV, "no data rows after the header"),
    (PENDULUM_CSV + "a,0,zero,0,3\na,0.1,0,0,3\n", r"line 2, column 'theta': 'zero' is not a finite number"),
    (PENDULUM_CSV + "a,0,0,nan,3\na,0.1,0,0,3\n", r"line 2, column 'theta_dot'"),
    (PENDULUM_CSV + "a,0,0,0,3\n,0.1,0,0,3\n", "line 3, column 'demo': empty"),
    (PENDULUM_CSV + "a,0,0,0,3\nb,0,0,0,3\nb,0.1,0,0,3\n", "demonstration 'a' has one row"),
    (PENDULUM_CSV + "a,,0,0,3\na,0.1,0,0,3\n", "line 2, column 't': empty"),
])
def test_malformed_csv_names_file_line_and_column(tmp_path, text, phrase):
    path = write(tmp_path, "t.csv", text)
    with pytest.raises(ValueError, match=phrase):
        read(path)


def test_a_byte_order_mark_is_accepted(tmp_path):
    path = tmp_path / "t.csv"
    path.write_bytes(b"\xef\xbb\xbf" + (PENDULUM_CSV + "a,0,0,0,3\na,0.1,0,0,3\n").encode())
    assert read(path).ids == ("a",)


def test_demo_ids_are_read_as_text(tmp_path):
    path = write(tmp_path, "t.csv", PENDULUM_CSV + "007,0,0,0,3\n007,0.1,0,0,3\n7,0,0,0,3\n7,0.1,0,0,3\n")
    assert read(path).ids == ("007", "7")


BASE = {"system": "pendulum", "state": {"low": [-3.14159, -8.0], "high": [3.14159, 8.0], "cells": [9, 9],
                                        "periodic": ["theta"]},
        "control": {"values": [-3.0, 0.0, 3.0]}, "time": {"dt": 0.1, "horizon": 10}, "reward": {"goal": [3.14, 0.0]}}


def changed(path, value):
    mapping = {k: dict(v) if isinstance(v, dict) else v for k, v in BASE.items()}
    *tables, key = path.split(".")
    target = mapping
    for t in tables:
        target = target.setdefault(t, {})
    if value is None:
        del target[key]
    else:
        target[key] = value
    return mapping


@pytest.mark.parametrize("path, value, phrase", [
    ("colour", "red", "key 'colour': unknown key or table"),
    ("state.width", 3, "key 'state.width': unknown key"),
    ("state.cells", None, "key 'state.cells': missing"),
    ("state.cells", [9, 1], "key 'state.cells': must be a list of 2 integers >= 2"),
    ("state.high", [3.14159, -9.0], "key 'state.high': every high must exceed its low"),
    ("state.low", [0.0, 0.0, 0.0], "key 'state.low': system 'pendulum' has 2 coordinates"),
    ("state.periodic", ["phi"], "'phi' is not a state coordinate"),
    ("control.values", [1.0, 1.0], "key 'control.values'.*distinct"),
    ("time.dt", 0, "key 'time.dt': must be a positive finite number"),
    ("time.horizon", 2.5, "key 'time.horizon': must be an integer >= 1"),
    ("discretization.scheme", "magic", "key 'discretization.scheme'"),
    ("reward.goal", [1.0], "key 'reward.goal': must be a list of 2 numbers"),
    ("reward.temperature", -1.0, "key 'reward.temperature'"),
    ("candidates.families", ["blob"], "unknown family 'blob'"),
    ("simulate.hidden", ["speed < 3"], "'speed' is not a state coordinate"),
    ("simulate.demonstrator", "human", r"must be one of \['soft', 'mppi'\]"),
    ("system", "rocket", "key 'system'"),
])
def test_a_bad_system_file_names_the_key(path, value, phrase):
    with pytest.raises(ValueError, match=phrase):
        system_from_mapping(changed(path, value), "sys.toml")


def test_a_system_file_that_is_not_toml_names_the_file(tmp_path):
    path = write(tmp_path, "s.toml", "system = pendulum\n")
    with pytest.raises(ValueError, match="s.toml: not valid TOML"):
        load_system(path)


@pytest.mark.parametrize("text, phrase", [
    ("theta_dot <= fast", "expected 1 numbers"),
    ("disk 0 0", "expected 3 numbers"),
    ("disk 0 0 -1", "radius must be positive"),
    ("box 1 0 0 1", "XMIN < XMAX"),
    ("theta_dot == 3", "write 'NAME <= VALUE'"),
])
def test_bad_constraint_text_is_explained(text, phrase):
    with pytest.raises(ValueError, match=phrase):
        parse_region(text, ("theta", "theta_dot"))


@pytest.mark.parametrize("change, phrase", [
    (dict(dt=-0.1), "dt: must be a positive number"),
    (dict(horizon=0), "horizon: must be an integer >= 1"),
    (dict(scheme="grid"), "scheme: must be one of"),
    (dict(samples=0), "samples: must be an integer >= 1"),
    (dict(controls=[[1.0, 2.0]]), "controls: need a list of controls with 1 value"),
])
def test_a_bad_problem_is_refused(change, phrase):
    with pytest.raises(ValueError, match=phrase):
        pendulum_problem().replace(**change)
