"""The benchmark's demonstrators (``benchmark.demonstrators``) against their truths: the recordings never enter
the hidden region and ride its limit only when it is approached; the braking filter against braking distances
in closed form."""

import numpy as np
import pytest

from mutual.constraints.continuous import Bound
from mutual.constraints.continuous.benchmark import case_recording, demonstrators
from mutual.constraints.continuous.benchmark.setups import SETUPS

from helpers.continuous import benchmark_case


@pytest.mark.parametrize("case_id, far", [("double_integrator-A-filter-narrow", False),
                                          ("double_integrator-F-mppi-narrow", True)])
def test_demonstrations_never_enter_their_truth_and_ride_it_only_when_approached(case_id, far):
    case = benchmark_case(case_id)
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
