"""The system TOML file (``systemfile``): a bad key is named, a file that is not TOML names the file, a 2-D control
set is read, and mistakes in a user's dynamics module name the file, the key and the module."""

import numpy as np
import pytest

from mutual.constraints.continuous import load_system, system_from_mapping

from helpers.continuous import CONTROLS_2D, planar_system, write


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


def test_a_two_dimensional_control_set_is_read(tmp_path):
    problem = load_system(planar_system(tmp_path)).problem
    assert problem.controls.tolist() == [[1.0, 0.0], [0.0, 1.0], [0.0, -1.0], [-1.0, 0.0], [0.0, 0.0]]
    assert problem.system.file == str((tmp_path / "planar.py").resolve())



SYSTEM_MISTAKES = [  # (case, spec, [control] values, [simulate] start, phrases of the error)
    ("a control of the wrong length", "planar:f", "[[1.0, 0.0], [0.0]]", "[0.25, 1.0]",
     ["key 'control.values'", "each a list of 2 numbers"]),
    ("a control that is not a number", "planar:f", "[[1.0, 0.0], [0.0, 'up']]", "[0.25, 1.0]",
     ["key 'control.values[1]': must be a list of 2 numbers, got [0.0, 'up']"]),
    ("dynamics for one state at a time (unpacking)", "one_state:f", CONTROLS_2D, "[0.25, 1.0]",
     ["key 'system'", "one_state.py", "written for one state at a time", "x[:, 0]"]),
    ("dynamics for one state at a time (one row back)", "one_row:f", CONTROLS_2D, "[0.25, 1.0]",
     ["key 'system'", "returned shape (2, 2) for states of shape (4, 2)", "written for one state at a time"]),
    ("sys.exit(0) at import", "exits:f", CONTROLS_2D, "[0.25, 1.0]",
     ["key 'system'", "importing module 'exits'", "exits.py", "called sys.exit(0)"]),
    ("a raise at import", "raises:f", CONTROLS_2D, "[0.25, 1.0]",
     ["importing module 'raises'", "raised RuntimeError: licence server unreachable at line 1 of"]),
    ("a start inside the hidden region", "planar:f", CONTROLS_2D, "[0.25, 1.6]",
     ["key 'simulate.start'", "[0.25, 1.6] lies inside the hidden region 'y <= 1.4'"]),
    ("own dynamics without state names", "planar:f", CONTROLS_2D, "[0.25, 1.0]",
     ["key 'state.names': missing: a system given as 'module:function' names its 2 state coordinates"]),
    ("own dynamics without control names", "planar:f", CONTROLS_2D, "[0.25, 1.0]",
     ["key 'control.names': missing: a system given as 'module:function' names its controls"]),
]


@pytest.mark.parametrize("case, spec, values, start, phrases", SYSTEM_MISTAKES, ids=[c[0] for c in SYSTEM_MISTAKES])
def test_mistakes_in_system_files_name_the_file_and_the_key(case, spec, values, start, phrases, tmp_path):
    path = planar_system(tmp_path, spec, values, start)
    if "without" in case:                                  # the same file, that table's names commented out
        text = path.read_text()
        at = text.index("[state]" if "state" in case else "[control]")
        path.write_text(text[:at] + text[at:].replace("names = ", "# names = ", 1))
    with pytest.raises(ValueError) as err:
        load_system(path)
    assert str(err.value).startswith(str(path)) and all(p in str(err.value) for p in phrases), err.value


@pytest.mark.parametrize("low, high, phrase", [
    ([-180.0, -8.0], [180.0, 8.0], "wraps with period high - low = 360, not 2 pi = 6.28319 (degrees?)"),
    ([0.0, -8.0], [3.14159, 8.0], "wraps with period high - low = 3.14159, not 2 pi"),
])
def test_a_periodic_angle_whose_box_is_not_one_turn_in_radians_is_refused(low, high, phrase):
    mapping = {"system": "pendulum", "state": {"low": low, "high": high, "cells": [9, 9], "periodic": ["theta"]},
               "control": {"values": [-3.0, 3.0]}, "time": {"dt": 0.1, "horizon": 10}, "reward": {"goal": [0.0, 0.0]}}
    with pytest.raises(ValueError, match=r"s\.toml: key 'state\.high': the periodic coordinate 'theta' \(rad\)"):
        system_from_mapping(mapping, "s.toml")
    with pytest.raises(ValueError) as err:
        system_from_mapping(mapping, "s.toml")
    assert phrase in str(err.value)
    mapping["state"].update(low=[0.0, -8.0], high=[2 * np.pi, 8.0])
    system_from_mapping(mapping, "s.toml")                                   # [0, 2 pi] is one turn too


def test_a_system_mapping_still_reads_without_a_file():
    mapping = {"system": "pendulum", "state": {"low": [-3.14, -8.0], "high": [3.14, 8.0], "cells": [9, 9]},
               "control": {"values": [-3.0, 3.0]}, "time": {"dt": 0.1, "horizon": 10}, "reward": {"goal": [3.14, 0.0]}}
    assert system_from_mapping(mapping, "inline").problem.system.file is None
