"""Chapter 6's statements checked by independent routes (``mutual.motion.legible.verify``): the DP minimiser
against enumeration of every control sequence, Lemma 6.4.1 exhaustively (and a check that can fail), log Z
by quadrature, L-BFGS on the raw ratio against the Riccati minimiser, the suboptimality multiplier
against a root search."""

import numpy as np
import pytest

from mutual.motion.legible import LinearDynamics, QuadraticCost, legible_trajectory, solve
from mutual.motion.legible import reaching_cost, single_integrator, verify
from mutual.motion.legible.qp import multi_distractor_qp
from mutual.motion.observer import likelihood_ratio_minimiser


DT, N = 0.01, 100
X0 = np.zeros(2)


def test_discrete_dynamic_programme_finds_the_enumerated_minimiser():
    """The DP minimiser of J1 - J0 equals the brute-force minimiser over every control sequence."""
    from mutual.motion.legible import verify
    import itertools
    for k in range(5):
        hyps = verify.random_discrete_hypotheses(np.random.default_rng(k), T=5)
        us = np.array(list(itertools.product((-1.0, 0.0, 1.0), repeat=5)))
        xs = np.c_[np.zeros(len(us)), np.cumsum(us, axis=1)]
        cost = lambda h: (h["b"] * us ** 2 + h["c"] * (xs[:, :-1] - h["h"]) ** 2).sum(1) + h["a"] * (xs[:, -1] - h["g"]) ** 2
        diff = cost(hyps[1]) - cost(hyps[0])
        robot, value = verify.discrete_legible_controls(hyps, 5)
        assert value == pytest.approx(diff.min(), abs=1e-12)
        assert diff[np.all(us == robot, axis=1)][0] == pytest.approx(diff.min(), abs=1e-12)


def test_lemma_check_holds_and_can_fail(monkeypatch):
    from mutual.motion.legible import verify
    hyps = verify.random_discrete_hypotheses(np.random.default_rng(3), T=6)
    out = verify.lemma_641_exhaustive(hyps, T=6)
    assert out["holds"] and out["outside"] == 0 and out["sequences"] == 3 ** 6 and out["regions"] > 10
    # a robot that does not minimise J1 - J0 misses the smallest non-empty rejection regions
    monkeypatch.setattr(verify, "discrete_legible_controls", lambda h, T: (np.zeros(T), 0.0))
    wrong = verify.lemma_641_exhaustive(hyps, T=6)
    assert not wrong["holds"] and wrong["outside"] > 0
    with pytest.raises(ValueError, match="T must be an integer from 1 to 10"):
        verify.lemma_641_exhaustive(hyps, T=11)


def test_log_partition_against_numerical_integration():
    """log Z of a 1-step, 1-control quadratic cost by quadrature."""
    from scipy.integrate import quad
    from mutual.motion.legible import verify
    import jax
    dyn = LinearDynamics(np.array([[0.9]]), np.array([[0.7]]))
    J = QuadraticCost(Q=np.array([[0.4]]), q=np.array([0.3]), R=np.array([[1.3]]), r=np.array([-0.2]),
                      QN=np.array([[2.0]]), qN=np.array([0.5]), const=0.1)
    x0 = np.array([0.8])
    with jax.enable_x64(True):
        arrays = verify._stage_arrays(dyn, J, 1)
        ours = verify.log_partition(jax.numpy.asarray(x0), arrays)
    cost = lambda u: J.value(np.array([[x0[0]], [0.9 * x0[0] + 0.7 * u]]), np.array([[u]]))
    assert ours == pytest.approx(np.log(quad(lambda u: np.exp(-cost(u)), -40, 40, epsabs=1e-13)[0]), abs=1e-9)


def test_lbfgs_on_the_raw_ratio_finds_the_riccati_minimiser():
    from mutual.motion.legible import random_lq_hypotheses, verify
    dyn, H0, H1, x0 = random_lq_hypotheses(np.random.default_rng(5), N=6)
    for alpha in (0.0, 0.5):
        u, fit = verify.lbfgs_likelihood_ratio_minimiser(dyn, H0, H1, x0, 6, alpha=alpha)
        ref = legible_trajectory(dyn, H1, H0, x0, 6, alpha).us
        np.testing.assert_allclose(u, ref, atol=1e-6 * np.abs(ref).max())
        assert likelihood_ratio_minimiser(dyn, H0, H1, x0, 6, alpha=alpha) == pytest.approx(ref, abs=1e-8)


def test_suboptimality_multiplier_is_the_alpha_that_spends_the_bound(reference):
    """The conic solver's multiplier equals the alpha found by a root search on our Riccati optimum's J1."""
    from scipy.optimize import brentq
    from mutual.motion.legible import verify
    dyn, J1, J0 = reference
    best = solve(dyn, J1, X0, N)
    j1_star = J1.value(best.xs, best.us)
    out = verify.suboptimality_multiplier(dyn, J1, J0, X0, N, 0.5)
    assert out["J1"] - out["J1_star"] == pytest.approx(0.5, rel=1e-6) and out["J1_star"] == pytest.approx(j1_star, rel=1e-9)
    spend = lambda a: J1.value(*(lambda s: (s.xs, s.us))(legible_trajectory(dyn, J1, J0, X0, N, a))) - j1_star - 0.5
    assert out["multiplier"] == pytest.approx(brentq(spend, 0.1, 100.0, xtol=1e-12), rel=1e-4)
    with pytest.raises(ValueError, match="epsilon must be a positive"):
        verify.suboptimality_multiplier(dyn, J1, J0, X0, N, 0.0)


AS_DT, AS_N = 0.2, 40                       # the section 6.5 check below


def test_lagrangian_check_holds_and_a_wrong_combination_fails():
    """Section 6.5: the QP's solution is the Riccati LQR of (1 + sum l) J1 - sum l_i J0_i with its multipliers;
    with other weights it is not (the check can fail)."""
    r = 4 * np.sqrt(2)
    goals = [r * np.array([np.cos(t), np.sin(t)]) for t in np.radians([45, 67.5, 90, 112.5, 135])]
    dyn = single_integrator(2, AS_DT)
    costs = [reaching_cost(g, AS_DT) for g in goals]
    d = np.array([np.linalg.norm(goals[i] - goals[2]) for i in (0, 1, 3, 4)])
    etas = -np.where(d < 1.01 * d.min(), 1.5, 1.0) * d ** 2
    out = verify.multi_distractor_kkt(dyn, costs[2], costs[:2] + costs[3:], np.zeros(2), AS_N, etas)
    assert out["positive"] == 2 and out["active"] == 2
    assert max(out[k] for k in ("solvers u", "solvers multipliers", "stationarity", "feasibility",
                                "complementarity", "Lagrangian (Riccati) u")) < 1e-6
    wrong = 1.5 * out["multipliers"]
    us = legible_trajectory(dyn, costs[2], costs[:2] + costs[3:], np.zeros(2), AS_N, wrong.sum(), weights=wrong).us
    _, us_qp, _ = multi_distractor_qp(dyn, costs[2], costs[:2] + costs[3:], np.zeros(2), AS_N, etas)
    assert np.abs(us - us_qp).max() > 1e-3 * np.abs(us_qp).max()
