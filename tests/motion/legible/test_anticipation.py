"""Anticipation: the receding horizon reproduces the time-weighted evidence optimum, its alphas can fail, the
reach-time ratio of a fixed alpha is the closed form, and the inverse-square schedule is what the t/T
weighting recovers; bad inputs (a table)."""

import numpy as np
import pytest

from mutual.motion import legible as leg
from mutual.motion.legible import anticipation, reaching_cost, single_integrator


DT, N = 0.01, 100
G0, G1 = np.array([-1.0, 1.0]), np.array([1.0, 1.0])
X0 = np.zeros(2)


def test_receding_horizon_reproduces_the_time_weighted_evidence_optimum(reference):
    """Section 6.5: replanning with an increasing alpha(t) retraces the optimum of J1 plus D&S's
    (T - t)-weighted evidence of every partial viewing, for several trade-offs beta."""
    dyn, J1, J0 = reference
    for beta in (0.5, 2.0):
        out = anticipation.receding_equivalence(dyn, J1, J0, X0, N, beta)
        assert out["miss"] < 1e-10 and out["gap"] < 1e-10
        assert out["positive"] and out["increasing"] and out["alphas"][-1] > 1e12   # the last step: task only


def test_receding_alphas_can_fail():
    """A control sequence that no replan produces is reported as a miss (the check is not vacuous)."""
    dyn, J1, J0 = single_integrator(2, DT), reaching_cost(G1, DT), reaching_cost(G0, DT)
    us = np.tile([0.0, 2.0], (N, 1))          # straight up: needs lateral speed 0, no alpha gives it
    xs = np.vstack([X0, np.cumsum(us * DT, axis=0)])
    _, miss, _ = anticipation.receding_alphas(dyn, J1, J0, xs, us, N)
    assert miss.max() > 0.1


def test_reach_time_ratio_of_fixed_alpha_is_the_closed_form():
    """A constant schedule alpha = 1 moves 1 + 2/alpha = 3 times faster along x than the H1 optimum, at any horizon."""
    for horizon, steps in ((1.0, 100), (20.0, 100)):
        table = anticipation.figure_62_scan((4.0,), [("linear", 1.0, 1.0)], horizon=horizon, N=steps)
        assert table["ratio"].iloc[0] == pytest.approx(3.0, rel=1e-9)


def test_inverse_square_schedule_is_what_the_t_minus_t_weighting_recovers(reference):
    """Section 6.5's equivalence on the reference problem: the recovered alpha(t) follows (1/beta) / (1 - t/T)^2
    to within 5% up to T/2 (it grows faster over the last steps)."""
    dyn, J1, J0 = reference
    for beta in (0.5, 2.0):
        e = anticipation.receding_equivalence(dyn, J1, J0, X0, N, beta)
        s = np.arange(N // 2 + 1) / N
        np.testing.assert_allclose(e["alphas"][:N // 2 + 1], anticipation.schedule("inverse-square", 1 / beta)(s), rtol=0.05)
    with pytest.raises(ValueError, match="kind must be one of"):
        anticipation.schedule("cubic", 1.0)


SMALL_DT, SMALL_N = 0.1, 10
SMALL_DYN = leg.single_integrator(2, SMALL_DT)
SMALL_J0, SMALL_J1 = leg.reaching_cost([-1.0, 1.0], SMALL_DT), leg.reaching_cost([1.0, 1.0], SMALL_DT)


CASES = [
    # anticipation and Explore
    (anticipation.weighted_evidence_optimum, (SMALL_DYN, SMALL_J1, SMALL_J0, X0, SMALL_N), dict(beta=0.0), ValueError, "beta must be"),
]


@pytest.mark.parametrize("fn,args,kwargs,error,phrase", CASES,
                         ids=[f"{i}-{c[0].__name__ if hasattr(c[0], '__name__') else c[0]}" for i, c in
                              enumerate(CASES)])
def test_bad_input_is_refused_with_a_clear_message(fn, args, kwargs, error, phrase):
    if error is None:
        out = fn(*args, **kwargs)
        assert np.all(np.isfinite(out.us))
        return
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value)
