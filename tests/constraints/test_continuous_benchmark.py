"""The continuous-constraint benchmark: its demonstrators, baselines, scorer, split and a quick run.

Independent truths: the hidden regions themselves (demonstrations never enter them and ride their
limit), braking distances in closed form, brute force for the largest empty disk and box, hand-made
answers with known errors. The quick suite itself runs in notebook 09's quick run, and is checked there
(tests/notebooks/test_chapter_results.py), the command line against the Python API on the same file.
"""

import math

import numpy as np
import pytest

from mutual.constraints.continuous import Bound, Box, Disk
from mutual.constraints.continuous.benchmark import Answer, all_cases, case_recording, cases, score
from mutual.constraints.continuous.benchmark import demonstrators, naive
from mutual.constraints.continuous.benchmark.setups import SETUPS


def _case(case_id):
    return next(c for c in all_cases() if c.id == case_id)


def test_split_holds_out_one_approached_bound_one_second_truth_and_one_unconstrained_case_per_system():
    held = cases("held-out")
    assert len(held) == 12 and len(cases("development")) == 24 and len(cases("all")) == 36
    for system in SETUPS:
        assert sorted(c.truth for c in held if c.system == system) == ["A", "B", "U"]
    assert not {c.id for c in held} & {c.id for c in cases("development")}


@pytest.mark.parametrize("case_id, far", [("double_integrator-A-filter-narrow", False),
                                          ("double_integrator-F-mppi-narrow", True)])
def test_demonstrations_never_enter_their_truth_and_ride_it_only_when_approached(case_id, far):
    case = _case(case_id)
    states = np.concatenate(case_recording(case).states)
    (truth,) = case.regions()
    assert not truth.inside(states).any()
    extreme = states[:, truth.dim].max() if truth.side == "upper" else states[:, truth.dim].min()
    gap = abs(extreme - truth.value)
    assert (gap > 0.3) if far else (gap < 0.05)


def test_braking_filter_stops_the_double_integrator_before_the_wall_in_closed_form():
    """With full braking a = 1 m/s^2, a cart at p moving at v > 0 stops at p + v^2 / 2: the filter must
    push (u = 1) exactly when the state after the push can still brake before the wall (up to the
    discrete braking's v h / 2 and the last step, 0.05 m here)."""
    setup = SETUPS["double_integrator"]
    wall = Bound(0, "upper", 2.3)
    ctx = demonstrators._Context(setup, [wall])
    h = setup.demo_dt
    p = np.linspace(1.0, 2.25, 40)
    v = np.full_like(p, 0.8)
    x = np.c_[p, v]
    u = ctx.filtered(x, np.ones((len(p), 1)))[:, 0]
    p1, v1 = p + v * h + 0.5 * h ** 2, v + h                          # after one push
    can_stop = p1 + v1 ** 2 / 2 <= wall.value - demonstrators.MARGIN - 0.05
    cannot = p1 + v1 ** 2 / 2 > wall.value - demonstrators.MARGIN + 0.05
    assert can_stop.sum() > 10 and cannot.sum() > 3
    assert np.all(u[can_stop] == 1.0) and np.all(u[cannot] < 1.0)


def test_largest_empty_disk_matches_a_brute_force_search_over_centres():
    rng = np.random.default_rng(3)
    angle = rng.uniform(0, 2 * np.pi, 400)
    ring = np.c_[np.cos(angle), np.sin(angle)] * rng.uniform(0.6, 1.5, 400)[:, None] + [0.3, -0.2]
    disk = naive.largest_empty_disk(ring)
    g = np.linspace(-1.0, 1.0, 201)
    centres = np.stack(np.meshgrid(g + 0.3, g - 0.2), axis=-1).reshape(-1, 2)
    radius = np.min(np.linalg.norm(centres[:, None] - ring[None], axis=2), axis=1)
    assert disk.radius == pytest.approx(radius.max(), abs=0.01)
    assert np.hypot(*np.subtract(disk.center, (0.3, -0.2))) < 0.15


def test_largest_empty_box_matches_brute_force_over_raster_rectangles():
    rng = np.random.default_rng(5)
    points = rng.uniform(0, 1, size=(25, 2))
    R = 12
    box = naive.largest_empty_box(points, raster=R)
    cell = np.minimum((points - points.min(0)) / ((points.max(0) - points.min(0)) / R), R - 1).astype(int)
    full = np.zeros((R, R), dtype=bool)
    full[cell[:, 0], cell[:, 1]] = True
    best = max((i1 - i0) * (j1 - j0) for i0 in range(R) for i1 in range(i0 + 1, R + 1) for j0 in range(R)
               for j1 in range(j0 + 1, R + 1) if not full[i0:i1, j0:j1].any())
    size = (points.max(0) - points.min(0)) / R
    area = (box.high[0] - box.low[0]) * (box.high[1] - box.low[1])
    assert area == pytest.approx(best * size[0] * size[1])
    assert not box.inside(points).any()


def test_naive_pick_takes_the_side_the_trajectories_ride_and_ignores_angles_that_wrap():
    t = np.linspace(0, 1, 500)
    states = np.c_[np.linspace(-3, 3, 500), np.minimum(3 * t, 1.2) - 0.5]   # the second rides 0.7 for 60 %
    bound = naive.naive_pick(states, np.array([-3.2, -2.0]), np.array([3.2, 2.0]), [True, False])
    assert (bound.dim, bound.side) == (1, "upper") and bound.value == pytest.approx(0.7)


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
    with open(case_csv(_case("pendulum-B-lagged-narrow"))) as f:
        speeds = [float(r["theta_dot"]) for r in csv.DictReader(f)]
    assert row["theta_dot min"] == min(speeds) and row["theta_dot max"] == max(speeds)
    assert row["theta_dot min"] >= -4.5 and row["truth"] == "theta_dot >= -4.5"      # the truth, ridden from above


def test_cases_on_a_two_worker_cluster_give_the_rows_of_one_process_in_case_order():
    """The cases are independent tasks: on an embedded Dask cluster of two workers, finishing in any order,
    the frame is the one a single process gives, row for row (the naive method: cheap, but every column)."""
    from mutual.constraints.continuous.benchmark import run_benchmark
    seen = []
    inline = run_benchmark("all", methods=("naive",), systems=["double_integrator"], scheduler="inline")
    spread = run_benchmark("all", methods=("naive",), systems=["double_integrator"], workers=2,
                           progress=lambda case, seconds: seen.append(case.id))
    assert list(spread["case"]) == [c.id for c in cases("all", ["double_integrator"])] == list(inline["case"])
    assert sorted(seen) == sorted(spread["case"])
    columns = [c for c in inline.columns if not c.endswith(": seconds")]
    assert spread[columns].equals(inline[columns])
