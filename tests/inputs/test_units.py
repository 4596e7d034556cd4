"""Angles in degrees where radians belong (mutual.inputs.angle_unit_warning): degree data of several
shapes are caught and named as degrees; radian data -- wrapped, slowly winding, noisy -- pass."""

import numpy as np
import pytest

from mutual.inputs import angle_unit_warning

RNG = np.random.default_rng(0)
T = np.arange(0, 6, 0.1)
RADIANS = [  # (case, values, times or None)
    ("headings in [-pi, pi)", RNG.uniform(-np.pi, np.pi, 200), None),
    ("a swing-up, wrapped", [np.mod(np.pi * np.tanh(T) + np.pi, 2 * np.pi) - np.pi], [T]),
    ("a slow spin of 1.4 turns, unwrapped", [1.5 * T], [T]),
    ("a heading near the wrap, with noise", [np.pi - 0.05 + 0.1 * RNG.random(60)], [T]),
    ("a fast pendulum at 8 rad/s", [np.mod(8 * T + np.pi, 2 * np.pi) - np.pi], [T]),
]
DEGREES = [  # (case, values, times or None, the phrases of the warning)
    ("headings in degrees", RNG.uniform(-180, 180, 200), None, ["degrees", "more than a full turn outside"]),
    ("a swing-up in degrees", [np.degrees(np.pi * np.tanh(T))], [T], ["degrees"]),
    ("a swing of 20 degrees", [20 * np.sin(3 * T)], [T], ["degrees", "more than a full turn outside"]),
    ("a swing of 8 degrees (within a turn)", [8 * np.sin(3 * T)], [T], ["degrees", "more than a quarter turn"]),
    ("headings in 0..360", RNG.uniform(0, 360, 50), None, ["degrees"]),
    ("milliradians", RNG.uniform(-3000, 3000, 50), None, ["a unit other than radians"]),
]


@pytest.mark.parametrize("case, values, times", RADIANS, ids=[c[0] for c in RADIANS])
def test_radians_pass(case, values, times):
    assert angle_unit_warning(values, "theta", times=times) is None


@pytest.mark.parametrize("case, values, times, phrases", DEGREES, ids=[c[0] for c in DEGREES])
def test_degrees_are_named(case, values, times, phrases):
    message = angle_unit_warning(values, "f.csv, column 'theta'", times=times)
    assert message and message.startswith("f.csv, column 'theta': the angles look like")
    assert all(p in message for p in phrases), message


def test_a_box_other_than_a_turn_centred_on_zero():
    assert angle_unit_warning(np.linspace(0, 2 * np.pi, 50), "h", low=0, high=2 * np.pi) is None
    assert "degrees" in angle_unit_warning(np.linspace(0, 350, 50), "h", low=0, high=2 * np.pi)
