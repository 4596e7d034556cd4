"""Legibility as hypothesis testing (chapter 6) against closed forms, dense algebra and cvxpy."""

import cvxpy as cp
import numpy as np
import pytest
from scipy.stats import multivariate_normal

from mutual.motion.legible import anticipation, explore as explore_legibility, predictability
from mutual.motion.legible import (distractor_mixture, double_integrator, legible_cost, legible_trajectory,
                                      linear_alpha_schedule, LinearDynamics, QuadraticCost, reaching_cost,
                                      receding_horizon, single_integrator, solve)
from mutual.motion.observer import (lifted_cost, likelihood_ratio_minimiser, log_boltzmann, log_boltzmann_prefix,
                                    log_likelihood_ratio, posterior_over_time, weighted_prefix_log_likelihood)
from mutual.motion.legible.qp import multi_distractor_qp

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


def test_prefix_log_likelihood_is_the_gaussian_marginal():
    """log P(u_{0:k} | H) against scipy's marginal of N(mean, H^-1) over the first k m coordinates."""
    dyn, J0, _, x0, N_ = random_hypotheses(6)
    H, h, _ = lifted_cost(dyn, J0, x0, N_)
    mean, cov = -np.linalg.solve(H, h), np.linalg.inv(H)
    us = np.random.default_rng(1).normal(size=(N_, 2))
    prefix = log_boltzmann_prefix(dyn, J0, x0, us)
    assert prefix[0] == 0.0
    for k in (1, 4, N_):
        d = 2 * k
        expected = multivariate_normal(mean[:d], cov[:d, :d]).logpdf(us.reshape(-1)[:d])
        assert prefix[k] == pytest.approx(expected, rel=1e-9)
    assert prefix[-1] == pytest.approx(log_boltzmann(dyn, J0, x0, us), rel=1e-12)


def test_posterior_over_time_is_bayes_rule():
    dyn, J0, J1, x0, N_ = random_hypotheses(7)
    us = np.random.default_rng(2).normal(size=(N_, 2))
    post = posterior_over_time(dyn, [J0, J1], x0, us, prior=[0.25, 0.75])
    np.testing.assert_allclose(post[0], [0.25, 0.75])
    np.testing.assert_allclose(post.sum(axis=1), 1.0)
    odds = np.log(post[-1, 0] / post[-1, 1])
    assert odds == pytest.approx(log_likelihood_ratio(dyn, J0, J1, x0, us) + np.log(0.25 / 0.75), rel=1e-9)


def test_weighted_prefix_log_likelihood_is_the_weighted_sum():
    dyn, J0, _, x0, N_ = random_hypotheses(8)
    us = np.random.default_rng(3).normal(size=(N_, 2))
    w = np.random.default_rng(4).uniform(size=N_)
    Hw, hw, cw = weighted_prefix_log_likelihood(dyn, J0, x0, N_, w)
    u = us.reshape(-1)
    assert -(0.5 * u @ Hw @ u + hw @ u + cw) == pytest.approx(w @ log_boltzmann_prefix(dyn, J0, x0, us)[1:], rel=1e-10)


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


def test_correlation_over_the_observers_own_model_is_zero_by_construction(reference):
    """With equal curvature, Cov(J1, J1 - J0) = a' H^-1 (H mean + h) = 0 exactly under P(u | H1)."""
    dyn, J1, J0 = reference
    H1, h1, _ = lifted_cost(dyn, J1, X0, N)
    H0, h0, _ = lifted_cost(dyn, J0, X0, N)
    np.testing.assert_allclose(H1, H0, atol=1e-12)
    a = h1 - h0                                   # J1 - J0 = a'u + const
    mean = -np.linalg.solve(H1, h1)
    assert abs(a @ np.linalg.solve(H1, H1 @ mean + h1)) < 1e-9
    table = predictability.predictability_correlations(dyn, J1, J0, X0, N, np.random.default_rng(0), n_samples=400)
    assert abs(table.set_index("motion set").loc[predictability.MOTION_SETS[-1], "r(J1, L)"]) < 0.2
    assert set(table["motion set"]) == set(predictability.MOTION_SETS)


def test_straight_lines_reach_their_end_points(reference):
    dyn = reference[0]
    ends = np.array([[1.0, 2.0], [-0.5, 0.3]])
    us = predictability.straight_lines(dyn, X0, N, ends)
    np.testing.assert_allclose(X0 + DT * us.sum(axis=1), ends, atol=1e-12)
    assert np.allclose(us, us[:, :1])                    # constant speed
    with pytest.raises(ValueError, match="cannot follow a straight line"):
        predictability.straight_lines(double_integrator(2, DT), np.zeros(4), N, np.ones((1, 4)))


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


def test_sparse_qp_equals_dense_qp():
    """The banded formulation (states as variables) solves the same QP as the lifted one."""
    rng = np.random.default_rng(9)
    for dyn in (single_integrator(2, DT), double_integrator(2, DT)):
        goals = rng.uniform(-2, 2, size=(4, 2)) + [0, 4]
        costs = [reaching_cost(np.concatenate([g, np.zeros(dyn.n - 2)]), DT, m=dyn.m) for g in goals]
        a = multi_distractor_qp(dyn, costs[0], costs[1:], np.zeros(dyn.n), 40, -1.0)
        b = multi_distractor_qp(dyn, costs[0], costs[1:], np.zeros(dyn.n), 40, -1.0, formulation="dense")
        np.testing.assert_allclose(a[1], b[1], atol=1e-6)
        np.testing.assert_allclose(a[0], b[0], atol=1e-6)
        np.testing.assert_allclose(a[2], b[2], atol=1e-5)


def test_distractor_list_is_a_weighted_sum(reference):
    dyn, J1, J0 = reference
    J2 = reaching_cost([0.0, 2.0], DT)
    mix = distractor_mixture([J0, J2], weights=[0.25, 0.75])
    xs, us = solve(dyn, J1, X0, N).xs, solve(dyn, J1, X0, N).us
    assert mix.value(xs, us) == pytest.approx(0.25 * J0.value(xs, us) + 0.75 * J2.value(xs, us))
    a = legible_trajectory(dyn, J1, [J0, J2], X0, N, 1.0)
    b = solve(dyn, 2.0 * J1 - (0.5 * J0 + 0.5 * J2), X0, N)
    np.testing.assert_allclose(a.us, b.us, atol=1e-12)


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


def test_explore_view_follows_its_inputs():
    """The Explore figure's plotted data change with alpha and the goal layout."""
    def lines(fig):
        return [ln.get_xydata() for ln in fig.axes[0].get_lines()]

    base, more = explore_legibility.legibility_view(alpha=1.0), explore_legibility.legibility_view(alpha=4.0)
    assert not np.allclose(lines(base)[1], lines(more)[1])
    d = explore_legibility.legibility_paths(alpha=1.0)
    np.testing.assert_allclose(d["legible"][-1], [1.5, 0.5], atol=1e-9)     # the reference case
    assert d["belief_legible"][-1] > d["belief_predictable"][-1]
    five = explore_legibility.legibility_view(n_goals=5, true_goal=1, spread=8.0, goal_height=4.0)
    assert len(five.axes[0].collections) == 5                                  # one marker per goal
    assert len(five.axes[1].get_lines()) == 3                                  # two beliefs and the prior


def test_notebook_results(executed_notebook):
    """The quick run checks the code path and the form of the results (issue 23); the numbers are the full run's."""
    res = executed_notebook("05_legibility_lqr")
    for cid in ("c6-lqr-analytic", "c6-thm642-same-optima", "c6-lemma641-rejection-region", "c6-multi-hypothesis-linear",
                "c6-receding-equivalent-weighting", "c6-dragan-eq11-linear", "c6-alpha-lagrange-multiplier",
                "c6-corollary-same-complexity", "c6-pred-leg-distinct-optima"):
        assert res[cid]["value"] is True, cid                       # checks that hold at any size
    for cid in ("c6-anticipative-leads-early", "c6-recreates-dragan-arcs", "c6-fig63-exterior-exaggerate",
                "c6-fig63-interior-juke", "c6-fig63-centre-juke", "c6-replan-online", "c6-pred-leg-correlated"):
        assert set(res[cid]["scan"]) == {"table", "seeds", "settings", "flips"}, cid
        assert res[cid]["scan"]["table"].startswith("table_6_scan_"), cid
    low, high = res["c6-h1-three-times-longer"]["value"]          # undetermined: a range over choices
    assert 0 < low <= high
    assert isinstance(res["c6-pred-leg-correlated"]["value"], bool)
    for cid in ("c6-lrt-most-powerful", "c6-posterior-needs-partitions", "c6-strictly-increasing-keeps-optima",
                "c7-priors-not-modelled"):
        assert res[cid]["value"] is True, cid                       # exact checks that hold at any size
    assert res["c6-nondecreasing-keeps-optima"]["value"] is False    # a constant function adds every motion
    assert "c6-h1-three-times-alpha1" not in res                   # now an extension, not a claim
    for cid, entry in res.items():
        assert entry["computed_by"].startswith("mutual.") and entry["note"], cid


# ---- independent routes for chapter 6's statements (mutual.motion.legible.verify) and Figures 6.2-6.3 ------------

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


def test_operation_counts_of_the_corollary():
    from mutual.motion.legible import timing
    table = timing.corollary_operation_counts((16, 64))
    assert (table["ratio legible / plain"] > 1.0).all() and (table["ratio legible / plain"] <= 2.0).all()
    assert table["plain LQR (flops)"].iloc[1] > 2 * table["plain LQR (flops)"].iloc[0]    # grows with N


def test_path_measures_of_figure_6_3():
    from mutual.motion.legible import path_measures as pm
    goal = np.array([-2.0, 4.0])
    straight = np.linspace([0.0, 0.0], goal, 101)
    assert pm.heading_turn(straight) == pytest.approx(0.0, abs=1e-6)
    assert pm.chord_deviation(straight, 0) == pytest.approx(0.0, abs=1e-12)
    assert pm.outward_excursion(straight, goal, -1) == pytest.approx(0.0, abs=1e-12)
    assert not pm.juke(straight, goal)["juke"]
    # sideways to the goal's x first, then straight up: a 90-degree juke that reaches the goal
    sideways = np.linspace([0.0, 0.0], [-2.0, 0.0], 11)
    up = np.linspace([-2.0, 0.0], goal, 91)[1:]
    jk = pm.juke(np.vstack([sideways, up]), goal)
    assert jk["juke"] and jk["turn"] == pytest.approx(90.0, abs=1e-6) and jk["gap"] == pytest.approx(0.0)
    # a path that bulges to the left of the start-goal segment strays outwards (towards smaller x)
    bulge = straight + np.c_[-np.sin(np.linspace(0, np.pi, 101)), np.zeros(101)]
    assert pm.outward_excursion(bulge, goal, -1) > 0.1 > pm.outward_excursion(bulge, goal, +1)


def test_correlation_scan_counts_per_seed_and_set(reference):
    dyn, J1, J0 = reference
    by_seed, by_set = predictability.correlation_scan(dyn, J1, J0, X0, N, range(2), n_samples=200)
    assert list(by_seed["seed"]) == [0, 1] and by_seed["sets with r >= threshold"].between(0, 4).all()
    assert set(by_set["motion set"]) == set(predictability.MOTION_SETS)
    assert (by_set["r_min"] <= by_set["r_max"]).all() and by_set["seeds_reaching"].between(0, 2).all()


def test_scan_entry_counts_cells_and_names_the_flips():
    import pandas as pd
    from mutual.compendium.claims import check_scan
    from mutual.compendium.scans import scan_entry
    table = pd.DataFrame({"a": [1.0, 2.0, 3.0], "kind": ["x", "y", "z"], "ok": [True, False, True]})
    entry = scan_entry(table, "ok", ["a", "kind"], "table_9_scan")
    assert entry["settings"] == [2, 3] and entry["seeds"] is None and "a 2, kind y" in entry["flips"]
    assert check_scan("c9-x", entry) is entry
    assert scan_entry(table.assign(ok=True), "ok", ["a"], "t", seeds=(9, 10))["flips"] == ""
    rare = scan_entry(table.assign(ok=[False, False, True]), "ok", ["kind"], "t")
    assert rare["settings"] == [1, 3] and rare["flips"] == "holds only in 1 of 3 cells: kind z"
