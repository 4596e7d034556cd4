"""How far recordings pin a region down (``benchmark.identifiability``): the slides of a disk and a box that no
recorded point tells apart, in closed form, and the recorded ranges against the case files read as plain CSV."""

import math

import numpy as np
import pytest

from mutual.constraints.continuous import Bound, Box, Disk

from helpers.continuous import benchmark_case


def _ring(center, radius, n=720):
    angle = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return np.c_[center[0] + radius * np.cos(angle), center[1] + radius * np.sin(angle)]


def test_a_disk_passed_on_two_sides_slides_along_the_lane_and_a_ringed_disk_cannot_move():
    """Closed forms: points on the lines y = +-(r + g) for x in [-3, 3] let the disk of radius r slide
    anywhere along x within the lattice (|dx| <= reach) but only |dy| <= g across (positions past a lane
    are free too, but it cannot slide there); a ring of radius r + g around it lets it slide at most g."""
    from mutual.constraints.continuous.benchmark import centre_slack
    from mutual.constraints.continuous.benchmark.identifiability import indistinguishable_moves
    truth, g = Disk((0, 1), (0.0, 0.0), 0.8), 0.05
    x = np.linspace(-3.0, 3.0, 6001)
    lanes = np.r_[np.c_[x, np.full_like(x, 0.8 + g)], np.c_[x, np.full_like(x, -0.8 - g)]]
    farthest, spans, at_reach = centre_slack(truth, lanes, reach=0.5, step=0.01)
    assert at_reach and spans[0] == pytest.approx(1.0) and spans[1] == pytest.approx(2 * g, abs=0.011)
    assert farthest == pytest.approx(math.hypot(0.5, g), abs=0.011)
    farthest, spans, at_reach = centre_slack(truth, _ring((0.0, 0.0), 0.8 + g), reach=0.5, step=0.01)
    assert not at_reach and g - 0.011 <= farthest <= g + 1e-9
    moves = indistinguishable_moves(truth, _ring((0.0, 0.0), 0.8 + g), reach=0.5, step=0.01)
    assert np.all(Disk((0, 1), (0.0, 0.0), g + 1e-9).inside(moves))     # brute force: every move within g
    beyond = indistinguishable_moves(truth, lanes, reach=2.0, step=0.05)  # past a lane (dy >= 1.65) is free too,
    assert np.abs(beyond[:, 1]).max() <= g + 1e-9                       # but cut off from the truth: not slack
    with pytest.raises(ValueError, match="need 0 < step <= reach"):
        centre_slack(truth, lanes, reach=0.5, step=0.0)


def test_a_box_seen_from_one_side_sinks_away_from_it_and_a_point_inside_leaves_no_slide():
    """Closed forms: one lane 0.05 above the box's top lets it slide along the lane and down as far as the
    lattice goes, and up by 0.05 only; a point inside the box as it is leaves no slide (nan), as do
    points everywhere."""
    from mutual.constraints.continuous.benchmark import centre_slack
    from mutual.constraints.continuous.benchmark.identifiability import indistinguishable_moves
    box = Box((0, 1), (-0.4, -1.2), (0.6, 0.4))
    x = np.linspace(-3.0, 3.0, 601)
    above = np.c_[x, np.full_like(x, 0.45)]
    moves = indistinguishable_moves(box, above, reach=0.5, step=0.05)
    assert moves[:, 1].max() == pytest.approx(0.05) and moves[:, 1].min() == pytest.approx(-0.5)
    assert np.ptp(moves[:, 0]) == pytest.approx(1.0)
    assert not len(indistinguishable_moves(box, np.r_[above, [[0.0, 0.0]]], reach=0.5, step=0.05))
    grid = np.stack(np.meshgrid(np.linspace(-3, 3, 121), np.linspace(-3, 3, 121)), axis=-1).reshape(-1, 2)
    farthest, spans, at_reach = centre_slack(box, grid, reach=0.5, step=0.05)
    assert math.isnan(farthest) and np.isnan(spans).all() and not at_reach
    with pytest.raises(ValueError, match="truth: must be a Disk or a Box"):
        centre_slack(Bound(0, "upper", 1.0), above)


def test_recorded_ranges_are_the_extremes_of_the_case_files_read_as_plain_csv():
    import csv
    from mutual.constraints.continuous.benchmark import case_csv, recorded_ranges
    row = recorded_ranges("development", ["pendulum"]).set_index("case").loc["pendulum-B-lagged-narrow"]
    with open(case_csv(benchmark_case("pendulum-B-lagged-narrow"))) as f:
        speeds = [float(r["theta_dot"]) for r in csv.DictReader(f)]
    assert row["theta_dot min"] == min(speeds) and row["theta_dot max"] == max(speeds)
    assert row["theta_dot min"] >= -4.5 and row["truth"] == "theta_dot >= -4.5"      # the truth, ridden from above
