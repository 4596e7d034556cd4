"""The benchmark's scorer (``benchmark.scoring``) on hand-made answers with known errors."""

import math

import pytest

from mutual.constraints.continuous import Bound, Box, Disk
from mutual.constraints.continuous.benchmark import Answer, score


@pytest.mark.parametrize("regions, truth, expected", [
    ((Bound(1, "upper", 5.2), Bound(1, "upper", 5.05)), [Bound(1, "upper", 5.0)],
     {"kind right": True, "error": 0.05, "false positives": 0}),
    ((Bound(0, "lower", -1.0), Bound(1, "upper", 5.1)), [Bound(1, "upper", 5.0)],
     {"kind right": False, "error": 0.1, "false positives": 1}),
    ((Bound(1, "lower", -4.0),), [Bound(1, "upper", 5.0)], {"kind right": False, "false positives": 1}),
    ((), [], {"kind right": True, "false positives": 0}),
    ((Bound(0, "upper", 3.0),), [], {"kind right": False, "false positives": 1}),
    ((Disk((0, 1), (0.3, 0.4), 0.7), Disk((0, 1), (3.0, 2.0), 0.4)), [Disk((0, 1), (0.0, 0.0), 0.8)],
     {"kind right": True, "error": 0.5, "size error": 0.1, "false positives": 1}),
    ((Box((0, 1), (-0.5, -1.0), (0.5, 0.6)),), [Box((0, 1), (-0.4, -1.2), (0.6, 0.4))],
     {"kind right": True, "error": math.hypot(0.1, 0.2), "size error": 0.0, "false positives": 0}),
    ((Disk((0, 1), (0.0, 0.0), 0.8),), [Box((0, 1), (-0.4, -1.2), (0.6, 0.4))], {"kind right": False}),
])
def test_score_of_hand_made_answers(regions, truth, expected):
    got = score(Answer(regions, (0.3,) * len(regions)), truth)
    for key, value in expected.items():
        assert got[key] == (pytest.approx(value) if isinstance(value, float) else value), key
    if "error" not in expected and truth:
        assert math.isnan(got["error"])


def test_score_counts_accepted_constraints_that_lowered_the_exact_likelihood():
    got = score(Answer((Bound(1, "upper", 5.1), Bound(0, "lower", 1.0)), (0.4, -0.2)), [Bound(1, "upper", 5.0)])
    assert got["lowered likelihood"] == 1
    assert score(Answer((Bound(1, "upper", 5.1),), None), [Bound(1, "upper", 5.0)])["lowered likelihood"] is None
