"""Chapter 6's statements about its observer on problems small enough to compute exactly: each check against
a route of its own, and each able to fail."""

import numpy as np
import pytest

from mutual.motion.legible import observer_checks as oc
from mutual.motion.legible import verify
from mutual.motion.legible.problem import reaching_cost, single_integrator


@pytest.fixture(scope="module")
def hypotheses():
    return verify.random_discrete_hypotheses(np.random.default_rng([0, 641, 0]))


def test_exact_log_probabilities_normalise(hypotheses):
    log_p = verify.exact_log_probabilities(hypotheses, T=5)
    assert log_p.shape == (2, 3 ** 5)
    np.testing.assert_allclose(np.exp(log_p).sum(axis=1), 1.0, atol=1e-12)


def test_likelihood_ratio_test_is_as_powerful_as_the_best_test(hypotheses):
    rows = oc.most_powerful_check(hypotheses, levels=(0.05, 0.3), T=6)
    assert all(r["gap"] < 1e-9 and r["power LRT"] >= r["level"] for r in rows)


def test_a_test_that_orders_by_the_wrong_statistic_loses_power(hypotheses):
    """The check can fail: ranking by P1 alone (not the ratio) is less powerful than the best test."""
    log_p0, log_p1 = verify.exact_log_probabilities(hypotheses, T=6)
    order = np.argsort(-log_p1)
    p0, p1 = np.exp(log_p0[order]), np.exp(log_p1[order])
    k = np.searchsorted(np.cumsum(p0), 0.05)
    power = p1[:k].sum()
    assert power < oc._best_power(log_p0, log_p1, 0.05) - 1e-3


def test_order_preserving_functions_and_the_constant(hypotheses):
    out = oc.order_preserving_check(hypotheses, T=6)
    assert not out["constant (non-decreasing)"]["same minimisers"]
    assert out["constant (non-decreasing)"]["minimisers"] == 3 ** 6
    assert not out["floor at the median (non-decreasing)"]["same minimisers"]
    assert all(v["same minimisers"] for k, v in out.items() if "strictly" in k)


@pytest.mark.parametrize("goal", [0.5, 2.0, -3.0])
def test_log_partition_quadrature_matches_the_gaussian_closed_form(goal):
    quadrature, closed = oc.log_partition_quadrature(single_integrator(1, 0.5), reaching_cost([goal], 0.5),
                                                     np.zeros(1), 3)
    assert quadrature == pytest.approx(closed, abs=1e-8)


def test_partition_functions_differ_exactly_by_the_optimal_costs():
    goals = np.array([[x, 4.0] for x in (-4.0, -2.0, 0.0, 2.0, 4.0)])
    rows = oc.posterior_partition_effect(goals, 1, np.zeros(2), N=40)
    for r in rows:
        assert r["log Z_truth - log Z_i"] == pytest.approx(r["J_i* - J_truth*"], abs=1e-9)
    assert max(r["posterior change"] for r in rows) > 1e-3
    equal = oc.posterior_partition_effect(np.array([[-1.0, 1.0], [1.0, 1.0]]), 1, np.zeros(2), N=40)
    assert equal[0]["posterior change"] < 1e-12


@pytest.mark.parametrize("call, message", [
    (lambda: oc.log_partition_quadrature(single_integrator(2, 0.5), reaching_cost([0.0, 1.0], 0.5), np.zeros(2), 3),
     "one control"),
    (lambda: oc.most_powerful_check(verify.random_discrete_hypotheses(np.random.default_rng(0)), levels=(1.0,), T=4),
     "levels must lie"),
    (lambda: verify.exact_log_probabilities([], T=12), "T must be an integer from 1 to 10"),
])
def test_bad_inputs_name_the_argument(call, message):
    with pytest.raises(ValueError, match=message):
        call()
