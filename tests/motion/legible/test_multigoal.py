"""Figure 6.3 with a bound per distractor pair: the per-pair bounds against the end-point geometry they stand
for, the one-shot QP's end point in closed form, the release schedule, the binding measure, the scan's rows and
the figure closest to the caption; bad inputs (a table)."""

import numpy as np
import pytest

from mutual.motion.legible import multigoal as mg
from mutual.motion.legible.problem import reaching_cost, single_integrator
from mutual.motion.legible.qp import multi_distractor_qp

DT, N = 0.2, 40


@pytest.mark.parametrize("omegas", [(0.5, -0.25), (-0.5, 0.5), (0.0, 0.0), (0.25, 0.25)])
def test_side_bounds_put_every_line_of_a_side_at_its_offset(omegas):
    """|x - g_j|^2 - |x - g_i|^2 = eta_i on the goals' row exactly at the side's offset from g_j."""
    goals = mg.row_goals()
    j, spacing = 1, 2.0
    etas = mg.side_bounds(goals, j, *omegas)
    others = np.delete(goals, j, 0)
    for g, eta in zip(others, etas):
        side = np.sign(g[0] - goals[j, 0])
        omega = omegas[0] if side < 0 else omegas[1]
        x = goals[j] + [side * omega * spacing, 0.0]
        assert np.sum((x - goals[j]) ** 2) - np.sum((x - g) ** 2) == pytest.approx(eta, abs=1e-12)


def test_one_qp_ends_at_the_unconstrained_end_clipped_to_the_slab():
    """For x' = u the bounded optimum is the straight line to the unconstrained end point
    (tau g + x0) / (1 + tau) moved into the slab [g - o_L, g + o_R] (a closed form derived by hand)."""
    goals = mg.row_goals()
    dyn, tau = single_integrator(2, DT), N * DT
    costs = [reaching_cost(g, DT) for g in goals]
    for j, wl, wr in [(1, 0.5, -0.25), (1, -0.5, 0.5), (2, 0.25, 0.25), (0, None, -1.0), (4, -0.5, None)]:
        etas = mg.side_bounds(goals, j, wl, wr)
        xs, _, _ = multi_distractor_qp(dyn, costs[j], costs[:j] + costs[j + 1:], np.zeros(2), N, etas,
                                       solver="active-set")
        free = tau * goals[j] / (1 + tau)
        low = goals[j, 0] - (np.inf if wl is None else 2 * wl)
        high = goals[j, 0] + (np.inf if wr is None else 2 * wr)
        np.testing.assert_allclose(xs[-1], [np.clip(free[0], low, high), free[1]], atol=1e-9)
        np.testing.assert_allclose(np.diff(xs, axis=0), np.diff(xs, axis=0)[:1].repeat(N, 0), atol=1e-9)


def test_released_bounds_loosen_to_the_bisectors():
    schedule = mg.released(np.array([-4.0, -8.0]), 0.5)
    np.testing.assert_allclose(schedule(0.0), [-4.0, -8.0])
    np.testing.assert_allclose(schedule(0.25), [-2.0, -4.0])
    np.testing.assert_allclose(schedule(0.5), [0.0, 0.0])
    np.testing.assert_allclose(schedule(0.9), [0.0, 0.0])


def test_replans_record_how_far_the_bounds_move_the_plan():
    goals = mg.row_goals()
    slack = mg.goal_path(goals, 1, np.zeros(2), mg.side_bounds(goals, 1, 0.5, 0.5), 1.0, N=20, every=10)
    assert all(np.allclose(r["end"], r["end_free"], atol=1e-9) and np.all(r["duals"] < 1e-9) for r in slack[2])
    strict = mg.goal_path(goals, 1, np.zeros(2), mg.side_bounds(goals, 1, 0.5, -0.5), 1.0, N=20, every=10)
    first = strict[2][0]
    assert first["end"][0] == pytest.approx(-3.0) and first["duals"].max() > 0     # pinned to Lambda_1's bisector
    assert mg.goal_measures(goals, 1, np.zeros(2), strict[0], strict[1], strict[2], 20.0)["binds"]
    assert not mg.goal_measures(goals, 1, np.zeros(2), slack[0], slack[1], slack[2], 20.0)["binds"]


def test_goal_cells_keep_only_feasible_pairs():
    cells = mg.goal_cells(5, (0.5, 0.0, -1.0), (0.5, 0.25, 0.0, -0.25, -0.5))
    assert sum(j == 0 for j, *_ in cells) == 3 and sum(j == 2 for j, *_ in cells) == 15
    assert all(wl + wr >= 0 for j, wl, wr in cells if j in (1, 2, 3))
    assert [c for c in cells if c[0] == 0] == [(0, None, 0.5), (0, None, 0.0), (0, None, -1.0)]


def test_figure_63_verdicts_read_the_measures():
    goals = mg.row_goals()
    omegas = [(None, -2.0), (0.5, -0.5), (0.5, -0.25), (-0.5, 0.5), (-2.0, None)]
    paths, plain, measures = mg.figure_63_paths(goals, np.zeros(2), omegas, 0.25, N=20, every=5)
    assert list(measures["role"]) == ["far end", "interior", "centre", "interior", "far end"]
    verdicts = mg.figure_63_verdicts(measures)
    assert verdicts["exterior"] == bool((measures.loc[[0, 4], "outward excursion"] >= 0.1).all())
    assert verdicts["centre"] == bool(measures.loc[2, "juke and anticipates"])
    np.testing.assert_allclose(paths[0][:, 0], -paths[4][:, 0], atol=1e-9)     # mirror images


@pytest.mark.parametrize("call, message", [
    (lambda: mg.side_bounds(mg.row_goals(), 1, None, 0.5), "needs a finite offset"),
    (lambda: mg.released([-1.0], 0.0), "release must be a fraction"),
    (lambda: mg.released([-1.0], 1.5), "release must be a fraction"),
    (lambda: mg.uniform_bound_paths(mg.row_goals(), np.zeros(2), 0.5), "eta0 must be a negative"),
])
def test_bad_inputs_name_the_argument(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_scan_rows_and_the_closest_figure():
    """A two-cell scan per goal: rows carry the cell and the verdict columns; best_cells picks, per goal, a passing
    binding cell when there is one (else the fallback), under the release where most goals pass."""
    cells = mg.goal_cells(5, (-2.0, 0.5), (0.5, -0.5))
    scan = mg.figure_63_scan((4.0,), (0.0,), (0.25,), cells, N=20, every=5)
    assert len(scan) == len(cells) and set(mg.PASSES.values()) <= set(scan.columns)
    slack = scan[(scan["role"] == "far end") & (scan["omega right"] == 0.5)]
    assert not slack["binds"].any()                                   # a bound at the bisector never binds
    fallback = [(None, 0.0), (0.5, 0.0), (0.5, 0.0), (0.0, 0.5), (0.0, None)]
    release, omegas = mg.best_cells(scan, fallback, releases=(0.25,))
    assert release == 0.25 and len(omegas) == 5
    far = scan[(scan["goal"] == "Lambda_1") & scan["binds"] & scan["exaggerates"]]
    assert omegas[0] == ((None, float(far["omega right"].iloc[0])) if len(far) else fallback[0])


def test_arc_goals_are_equally_far_from_the_start():
    goals = mg.arc_goals()
    np.testing.assert_allclose(np.linalg.norm(goals, axis=1), 4 * np.sqrt(2))
    np.testing.assert_allclose(goals[2], [0.0, 4 * np.sqrt(2)], atol=1e-12)
