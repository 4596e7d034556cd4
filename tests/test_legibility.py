"""Legibility as hypothesis testing (chapter 6) against closed forms, dense algebra and cvxpy."""

import cvxpy as cp
import numpy as np
import pytest
from scipy.stats import multivariate_normal

from mutual.motion.legibility import (legible_cost, legible_trajectory, linear_alpha_schedule, LinearDynamics, QuadraticCost, reaching_cost, receding_horizon, single_integrator, solve)
from mutual.motion.observer import (lifted_cost, likelihood_ratio_minimiser, log_boltzmann, log_likelihood_ratio)
from mutual.motion.qp import multi_distractor_qp

DT, N = 0.01, 100
G0, G1 = np.array([-1.0, 1.0]), np.array([1.0, 1.0])
X0 = np.zeros(2)


@pytest.fixture(scope="module")
def reference():
    return single_integrator(2, DT), reaching_cost(G1, DT), reaching_cost(G0, DT)


def test_reference_case_alpha_one(reference):
    """The issue's reference: alpha = 1 gives the constant control (1.5, 0.5), x_N = (1.5, 0.5)."""
    dyn, J1, J0 = reference
    sol = legible_trajectory(dyn, J1, J0, X0, N, alpha=1.0)
    np.testing.assert_allclose(sol.us, np.tile([1.5, 0.5], (N, 1)), atol=1e-12)
    np.testing.assert_allclose(sol.xs[-1], [1.5, 0.5], atol=1e-12)
    np.testing.assert_allclose(solve(dyn, J1, X0, N).xs[-1], [0.5, 0.5], atol=1e-12)


@pytest.mark.parametrize("alpha", [0.3, 1.0, 4.0])
def test_closed_form_endpoint(reference, alpha):
    """Minimising alpha |x|^2 - 2((1+alpha) g1 - g0).x + alpha |x|^2 / (N dt) gives x_N = (g1 + (g1-g0)/alpha) / 2."""
    dyn, J1, J0 = reference
    sol = legible_trajectory(dyn, J1, J0, X0, N, alpha)
    np.testing.assert_allclose(sol.xs[-1], (G1 + (G1 - G0) / alpha) / 2, atol=1e-12)


@pytest.mark.parametrize("alpha", [0.0, -0.5, -1.0, -3.0])
def test_alpha_nonpositive_is_unbounded(reference, alpha):
    dyn, J1, J0 = reference
    with pytest.raises(ValueError, match="unbounded"):
        legible_trajectory(dyn, J1, J0, X0, N, alpha)


def test_unbounded_distractor_with_more_effort_raises():
    """J1 - J0 with J0 penalising effort more than J1 is concave in u: refused."""
    dyn = single_integrator(2, DT)
    with pytest.raises(ValueError, match="unbounded"):
        solve(dyn, reaching_cost(G1, DT) - reaching_cost(G0, DT, effort_weight=2.0), X0, N)


def test_cost_algebra_and_lifting():
    rng = np.random.default_rng(0)
    dyn = LinearDynamics(np.eye(2) + 0.1 * rng.normal(size=(2, 2)), rng.normal(size=(2, 1)))
    J1, J0 = random_cost(rng, 2, 1, 8), random_cost(rng, 2, 1, 8)
    us = rng.normal(size=(8, 1))
    x0 = rng.normal(size=2)
    xs = rollout(dyn, x0, us)
    L = legible_cost(J1, J0, 0.7)
    assert L.value(xs, us) == pytest.approx(1.7 * J1.value(xs, us) - J0.value(xs, us))
    H, h, c = lifted_cost(dyn, L, x0, 8)
    u = us.reshape(-1)
    assert 0.5 * u @ H @ u + h @ u + c == pytest.approx(L.value(xs, us))


def rollout(dyn, x0, us):
    xs = [x0]
    for u in us:
        xs.append(dyn.A @ xs[-1] + dyn.B @ u)
    return np.array(xs)


def random_cost(rng, n, m, N, effort=1.0):
    """A random time-varying convex quadratic cost."""
    L = rng.normal(size=(N, n, n))
    Lr = rng.normal(size=(N, m, m))
    LN = rng.normal(size=(n, n))
    return QuadraticCost(Q=L @ L.transpose(0, 2, 1) / n, q=rng.normal(size=(N, n)),
                         R=Lr @ Lr.transpose(0, 2, 1) / m + effort * np.eye(m), r=rng.normal(size=(N, m)),
                         QN=LN @ LN.T, qN=rng.normal(size=n), const=rng.normal())


def random_hypotheses(seed, n=2, m=2, N=10):
    """Random LQ hypotheses with J1 curved more than J0, so that Lambda has a minimiser."""
    rng = np.random.default_rng(seed)
    dyn = LinearDynamics(np.eye(n) + 0.2 * rng.normal(size=(n, n)), rng.normal(size=(n, m)))
    J0 = random_cost(rng, n, m, N)
    J1 = J0 + random_cost(rng, n, m, N, effort=0.5)     # H1 - H0 positive definite
    return dyn, J0, J1, rng.normal(size=n), N


def test_log_boltzmann_is_a_gaussian_density():
    """P(u | H) = exp(-J(u)) / Z is the Gaussian N(-H^-1 h, H^-1) (checked with scipy)."""
    dyn, J0, _, x0, N_ = random_hypotheses(1)
    H, h, _ = lifted_cost(dyn, J0, x0, N_)
    rng = np.random.default_rng(2)
    for _ in range(3):
        us = rng.normal(size=(N_, 2))
        expected = multivariate_normal(-np.linalg.solve(H, h), np.linalg.inv(H)).logpdf(us.reshape(-1))
        assert log_boltzmann(dyn, J0, x0, us) == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("alpha", [0.0, 0.5])
def test_theorem_642_on_random_lq_problems(seed, alpha):
    """Theorem 6.4.2: the minimiser of Lambda (from the Gaussians) is the Riccati minimiser of J1 - J0."""
    dyn, J0, J1, x0, N_ = random_hypotheses(seed)
    u_lambda = likelihood_ratio_minimiser(dyn, J0, J1, x0, N_, alpha=alpha)
    u_riccati = legible_trajectory(dyn, J1, J0, x0, N_, alpha).us
    np.testing.assert_allclose(u_lambda, u_riccati, atol=1e-8)
    # and it is a minimum of log Lambda + alpha J1 itself: random perturbations only increase it
    xs = rollout(dyn, x0, u_riccati)
    best = log_likelihood_ratio(dyn, J0, J1, x0, u_riccati) + alpha * J1.value(xs, u_riccati)
    rng = np.random.default_rng(seed)
    for _ in range(20):
        u = u_riccati + 1e-2 * rng.normal(size=u_riccati.shape)
        assert log_likelihood_ratio(dyn, J0, J1, x0, u) + alpha * J1.value(rollout(dyn, x0, u), u) > best


def test_equal_curvature_means_lambda_is_exp_cost_difference(reference):
    """For x' = u with eq. (6.17) both hypotheses have the same Hessian, so Z0 = Z1 and log Lambda = J1 - J0."""
    dyn, J1, J0 = reference
    us = np.random.default_rng(3).normal(size=(N, 2))
    xs = rollout(dyn, X0, us)
    assert log_likelihood_ratio(dyn, J0, J1, X0, us) == pytest.approx(J1.value(xs, us) - J0.value(xs, us))


def test_qp_one_distractor_equals_weighted_lqr(reference):
    """min J1 s.t. J1 - J0 <= eta has the solution of (1 + alpha) J1 - J0 with alpha = 1 / multiplier."""
    dyn, J1, J0 = reference
    xs, us, duals = multi_distractor_qp(dyn, J1, [J0], X0, N, etas=-4.0)
    assert J1.value(xs, us) - J0.value(xs, us) == pytest.approx(-4.0, abs=1e-6)
    sol = legible_trajectory(dyn, J1, J0, X0, N, alpha=1.0 / duals[0])
    np.testing.assert_allclose(us, sol.us, atol=1e-6)
    np.testing.assert_allclose(xs[-1], [1.0, 0.5], atol=1e-6)   # closed form: x_N = (g1 + (g1-g0)/2) / 2


def test_qp_many_distractors_constraints_and_lagrangian():
    dyn = single_integrator(2, DT)
    goals = np.array([[x, 4.0] for x in (-4, -2, 0, 2, 4)])
    Js = [reaching_cost(g, DT) for g in goals]
    for i in (0, 1):
        others = [J for j, J in enumerate(Js) if j != i]
        etas = np.array([-2.0, -1.0, -3.0, -2.5])
        xs, us, duals = multi_distractor_qp(dyn, Js[i], others, X0, N, etas)
        gaps = np.array([Js[i].value(xs, us) - J.value(xs, us) for J in others])
        assert np.all(gaps <= etas + 1e-6)
        assert np.all(duals >= -1e-9) and np.any(duals > 1e-6)
        # the Lagrangian's stationary point is the weighted LQR (1 + sum l) J1 - sum l_i J0_i
        weighted = (1 + duals.sum()) * Js[i] - sum((d * J for d, J in zip(duals, others)), 0 * Js[i])
        np.testing.assert_allclose(solve(dyn, weighted, X0, N).us, us, atol=1e-5)


def test_qp_matches_direct_cvxpy_on_endpoint():
    """For x' = u the QP reduces to a small problem in x_N (straight line): cross-check with cvxpy."""
    dyn = single_integrator(2, DT)
    goals = np.array([[-4.0, 4.0], [-2.0, 4.0], [0.0, 4.0]])
    Js = [reaching_cost(g, DT) for g in goals]
    xs, _, _ = multi_distractor_qp(dyn, Js[1], [Js[0], Js[2]], X0, N, -2.0)
    x = cp.Variable(2)
    T = N * DT
    # |x - g1|^2 - |x - g0|^2 <= eta, expanded into its affine form
    cons = [2 * x @ (g - goals[1]) + goals[1] @ goals[1] - g @ g <= -2.0 for g in goals[[0, 2]]]
    cp.Problem(cp.Minimize(cp.sum_squares(x - goals[1]) + cp.sum_squares(x) / T), cons).solve()
    np.testing.assert_allclose(xs[-1], x.value, atol=1e-5)


def test_qp_refuses_nonconvex_constraint():
    dyn = single_integrator(2, DT)
    J1 = reaching_cost(G1, DT)
    J0 = reaching_cost(G0, DT, effort_weight=2.0)      # J1 - J0 concave in u
    with pytest.raises(ValueError, match="not convex"):
        multi_distractor_qp(dyn, J1, [J0], X0, N, -1.0)


def test_receding_horizon_constant_alpha_is_time_consistent(reference):
    dyn, J1, J0 = reference
    xs, us, alphas = receding_horizon(dyn, J1, J0, X0, N, lambda s: 1.0, every=7)
    np.testing.assert_allclose(us, legible_trajectory(dyn, J1, J0, X0, N, 1.0).us, atol=1e-10)
    assert np.all(alphas == 1.0)


@pytest.mark.parametrize("every", [1, 7])
def test_receding_horizon_matches_naive_replanning(every):
    """The batched sweep equals re-solving every tail problem one by one (time-varying costs too)."""
    rng = np.random.default_rng(5)
    N_ = 30
    A = np.eye(2) + 0.05 * rng.normal(size=(N_, 2, 2))
    dyn = LinearDynamics(A, 0.1 * rng.normal(size=(N_, 2, 2)) + 0.1 * np.eye(2))
    J1 = reaching_cost(G1, 0.1) + random_cost(rng, 2, 2, N_, effort=0.0) * 0.05
    J0 = reaching_cost(G0, 0.1)
    schedule = linear_alpha_schedule(0.5, 3.0)
    xs, us, _ = receding_horizon(dyn, J1, J0, X0, N_, schedule, every=every)
    x, naive = X0, []
    for start in range(0, N_, every):
        rest = N_ - start
        plan = legible_trajectory(dyn.stages(start, rest), J1.stages(start, rest), J0.stages(start, rest), x, rest,
                                  schedule(start / N_))
        steps = min(every, rest)
        naive.extend(plan.us[:steps])
        x = plan.xs[steps]
    np.testing.assert_allclose(us, np.array(naive), atol=1e-9)
    np.testing.assert_allclose(xs[-1], x, atol=1e-9)


def test_receding_horizon_refuses_unbounded_replans(reference):
    dyn, J1, J0 = reference
    with pytest.raises(ValueError, match="unbounded"):
        receding_horizon(dyn, J1, J0, X0, N, lambda s: 1.0 - 2.0 * s)   # alpha reaches <= 0


def test_receding_horizon_anticipates(reference):
    """An increasing alpha(t) moves towards x > 0 earlier than the fixed-alpha plan and the H1 optimum."""
    dyn, J1, J0 = reference
    schedule = linear_alpha_schedule(0.25, 4.0)
    xs, us, alphas = receding_horizon(dyn, J1, J0, X0, N, schedule)
    assert np.all(np.diff(alphas) >= 0) and alphas[0] == 0.25
    plain = solve(dyn, J1, X0, N).xs
    assert xs[10, 0] > 3 * plain[10, 0]
    # the first step follows the one-shot plan with alpha(0)
    np.testing.assert_allclose(us[0], legible_trajectory(dyn, J1, J0, X0, N, 0.25).us[0], atol=1e-12)


@pytest.mark.parametrize("bad", [(0.0, 1.0), (2.0, 1.0), (-1.0, 1.0)])
def test_schedule_must_increase_from_positive(bad):
    with pytest.raises(ValueError, match="alpha_start"):
        linear_alpha_schedule(*bad)


def test_bad_inputs_name_the_argument():
    with pytest.raises(ValueError, match="goal"):
        reaching_cost([np.nan, 1.0])
    with pytest.raises(ValueError, match="dt"):
        single_integrator(2, dt=0.0)
    with pytest.raises(ValueError, match="cost field R"):
        QuadraticCost(Q=np.eye(2), q=np.zeros(2), R=np.ones(3), r=np.zeros(2), QN=np.eye(2), qN=np.zeros(2))
    with pytest.raises(ValueError, match="B must be"):
        LinearDynamics(np.eye(2), np.ones((3, 1)))
    with pytest.raises(ValueError, match="alpha must be a finite"):
        legible_cost(reaching_cost(G1), reaching_cost(G0), np.inf)


def test_notebook_results(executed_notebook):
    res = executed_notebook("05_legibility_lqr")
    assert res["c6-lqr-analytic"]["value"] is True
    assert res["c6-thm642-same-optima"]["value"] is True
    assert res["c6-multi-hypothesis-linear"]["value"] is True
    assert res["c6-anticipative-leads-early"]["value"] is True
    assert res["c6-fig63-exterior-exaggerate"]["value"] is True
    assert 1.0 < res["c6-h1-three-times-longer"]["value"] < 20.0
