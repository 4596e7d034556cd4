"""The system TOML file (``systemfile``): a bad key is named, and a file that is not TOML names the file."""

import pytest

from mutual.constraints.continuous import load_system, system_from_mapping

from helpers.continuous import write


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
