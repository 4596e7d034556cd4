"""The LQ problem (eq. 6.17's reaching cost, single and double integrators): the double integrator is the
exact zero-order hold, and the objects print short summaries; bad inputs (a table)."""

import numpy as np
import pytest

from mutual.motion import legible as leg
from mutual.motion.legible import double_integrator

from helpers.lq import random_cost


DT, N = 0.01, 100
X0 = np.zeros(2)


def test_double_integrator_is_the_exact_zero_order_hold():
    from scipy.signal import cont2discrete
    Ac = np.block([[np.zeros((2, 2)), np.eye(2)], [np.zeros((2, 2)), np.zeros((2, 2))]])
    Bc = np.vstack([np.zeros((2, 2)), np.eye(2)])
    Ad, Bd, *_ = cont2discrete((Ac, Bc, np.eye(4), np.zeros((4, 2))), 0.05)
    dyn = double_integrator(2, 0.05)
    np.testing.assert_allclose(dyn.A, Ad, atol=1e-14)
    np.testing.assert_allclose(dyn.B, Bd, atol=1e-14)


def test_reprs_are_short(reference):
    dyn, J1, _ = reference
    assert repr(dyn) == "LinearDynamics(n=2, m=2, time-invariant)"
    assert repr(J1) == "QuadraticCost(n=2, m=2, time-invariant, const=2)"
    assert "per-stage over 5 stages" in repr(random_cost(np.random.default_rng(0), 2, 1, 5))


SMALL_DT, SMALL_N = 0.1, 10
SMALL_DYN = leg.single_integrator(2, SMALL_DT)
SMALL_J0, SMALL_J1 = leg.reaching_cost([-1.0, 1.0], SMALL_DT), leg.reaching_cost([1.0, 1.0], SMALL_DT)
US = np.ones((SMALL_N, 2))
NAN_US = US.copy()
NAN_US[3, 1] = np.nan
XS = np.linspace([0.0, 0.0], [1.0, 1.0], SMALL_N + 1)
I2 = np.eye(2)
SKEW_R = np.array([[1.0, 5.0], [-5.0, 1.0]])


CASES = [
    # costs and dynamics
    (leg.QuadraticCost, (np.eye(2), np.zeros(2), SKEW_R, np.zeros(2), I2, np.zeros(2)), {}, ValueError,
     "cost field R is not symmetric"),
    (leg.QuadraticCost, (np.full((2, 2), np.nan), np.zeros(2), I2, np.zeros(2), I2, np.zeros(2)), {}, ValueError,
     "cost field Q contains non-finite"),
    (leg.LinearDynamics, (np.array([[1.0, np.nan], [0.0, 1.0]]), I2), {}, ValueError, "dynamics A contains non-finite"),
    (leg.reaching_cost, ([1.0, 1.0],), dict(dt=np.inf), ValueError, "dt and effort_weight must be positive"),
    (leg.single_integrator, (0,), {}, ValueError, "dim must be a positive integer"),
    (leg.double_integrator, (2, -0.1), {}, ValueError, "dt must be a positive finite number"),
    (SMALL_J1.value, (XS, NAN_US), {}, ValueError, "us contains non-finite"),
    (leg.solve, (SMALL_DYN, leg.reaching_cost([1.0, 1.0, 1.0], SMALL_DT), X0, SMALL_N), {}, ValueError, "the cost is for n = 3"),
    (leg.solve, (SMALL_DYN, SMALL_J1, X0, SMALL_N), dict(backend="jax"), None, None),           # a valid call, for contrast
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
