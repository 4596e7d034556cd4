"""The one set of value checks (mutual.inputs.values): what each refuses, in one wording that names the
value and shows it with every digit; and number_text, which must read back as the very same number."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from mutual.inputs import check_number, count, exact_doubles, number_text, positive, probability, real

CASES = [  # (value, bounds and kind, the message after "x must ")
    (-1, dict(low=0, low_open=True), "be a positive finite number, got -1"),
    (float("inf"), dict(low=0, low_open=True), "be a positive finite number, got inf"),
    ("3", dict(low=0), "be a non-negative finite number, got '3'"),
    (-3, dict(low=-2), "be a number >= -2, got -3"),
    (0.0, dict(low=0, high=1, low_open=True, high_open=True), "lie strictly between 0 and 1, got 0.0"),
    (True, {}, "be a finite number, got True"),
    (1.5, dict(low=0, high=1), "be a number in [0, 1], got 1.5"),
    (1.0, dict(low=0, high=1, high_open=True), "be a number in [0, 1), got 1.0"),
    (-0.5000001, dict(low=-0.5, high=1), "be a number in [-0.5, 1], got -0.5000001"),
    (2.5, dict(low=1, integer=True), "be an integer >= 1, got 2.5"),
    (4.0, dict(low=2, integer=True), "be an integer >= 2, got 4.0"),
    (51, dict(low=0, high=50, integer=True), "be an integer in 0..50, got 51"),
    (2.5, dict(low=1, whole=True), "be an integer >= 1, got 2.5"),
    (10 ** 400, dict(low=1, integer=True), "be an integer >= 1, got 10000000000000000000...(401 characters)"),
    (np.float64(np.nan), {}, "be a finite number, got nan"),
    (None, dict(low=1, high=3), "be a finite number in [1, 3], got None"),
]


@pytest.mark.parametrize("value, bounds, message", CASES, ids=[c[2][:40] for c in CASES])
def test_bad_values_are_named_with_every_digit(value, bounds, message):
    with pytest.raises(ValueError) as err:
        check_number("x", value, **bounds)
    assert str(err.value) == "x must " + message


@pytest.mark.parametrize("value, bounds, expected", [
    (0.5, dict(low=0, high=1), 0.5), (np.int64(3), dict(low=1, integer=True), 3), (40.0, dict(whole=True), 40),
    (np.array(2.5), {}, 2.5), (2 ** 60 + 1, dict(integer=True), 2 ** 60 + 1),
])
def test_good_values_pass_as_numbers(value, bounds, expected):
    got = check_number("x", value, **bounds)
    assert got == expected and type(got) is type(expected)


def test_the_shortcuts_are_the_same_checks():
    assert positive("p", 2) == 2.0 and count("n", 40.0) == 40 and probability("a", 0.05) == 0.05
    for call, phrase in [(lambda: positive("p", 0), "p must be a positive finite number"),
                         (lambda: count("n", 0), "n must be an integer >= 1"),
                         (lambda: probability("a", 1), "a must lie strictly between 0 and 1"),
                         (lambda: check_number("key 'k'", -1, low=0, sep=": "), "key 'k': must be a non-negative")]:
        with pytest.raises(ValueError, match=phrase.replace("(", r"\(").replace(")", r"\)")):
            call()


@pytest.mark.parametrize("value, expected", [(True, None), ("1", None), (np.bool_(True), None), (np.float32(0.5), 0.5),
                                             (np.array(3), 3.0), (10 ** 400, None), (7, 7.0)])
def test_real_accepts_real_numbers_only(value, expected):
    assert real(value) == expected


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_number_text_reads_back_as_the_same_double(x):
    text = number_text(x)
    assert float(text) == x and math.copysign(1, float(text)) == math.copysign(1, x)
    assert len(text) <= len(repr(x))


def test_integers_beyond_a_doubles_digits_are_refused_with_that_reason():
    assert exact_doubles("y", np.array([1, 2, 2 ** 53])).tolist() == [1.0, 2.0, 2.0 ** 53]
    with pytest.raises(ValueError, match="y: 9007199254740992 and 9007199254740993 differ only beyond the 15-17"):
        exact_doubles("y", np.array([2 ** 53, 2 ** 53 + 1], dtype=object))
