"""The legible objective (1 + alpha) J1 - J0 and its receding horizon (eqs. 6.13-6.16) against closed forms,
dense algebra, Theorem 6.4.2's likelihood-ratio minimiser and naive replanning; bad inputs (tables)."""

import numpy as np
import pytest

from mutual.motion import legible as leg
from mutual.motion.legible import (LinearDynamics, QuadraticCost, distractor_mixture, legible_cost,
                                   legible_trajectory, linear_alpha_schedule, reaching_cost, receding_horizon,
                                   single_integrator, solve)
from mutual.motion.observer import lifted_cost, likelihood_ratio_minimiser, log_likelihood_ratio

from helpers.lq import random_cost, random_hypotheses, rollout


DT, N = 0.01, 100
G0, G1 = np.array([-1.0, 1.0]), np.array([1.0, 1.0])
X0 = np.zeros(2)


def test_reference_case_alpha_one(reference):
    """The reference case: alpha = 1 gives the constant control (1.5, 0.5), x_N = (1.5, 0.5)."""
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


def test_distractor_list_is_a_weighted_sum(reference):
    dyn, J1, J0 = reference
    J2 = reaching_cost([0.0, 2.0], DT)
    mix = distractor_mixture([J0, J2], weights=[0.25, 0.75])
    xs, us = solve(dyn, J1, X0, N).xs, solve(dyn, J1, X0, N).us
    assert mix.value(xs, us) == pytest.approx(0.25 * J0.value(xs, us) + 0.75 * J2.value(xs, us))
    a = legible_trajectory(dyn, J1, [J0, J2], X0, N, 1.0)
    b = solve(dyn, 2.0 * J1 - (0.5 * J0 + 0.5 * J2), X0, N)
    np.testing.assert_allclose(a.us, b.us, atol=1e-12)


@pytest.mark.parametrize("every", [1, 4])
def test_shared_quadratic_receding_horizon_matches_naive_replanning(every):
    """Time-varying dynamics and costs that differ only in their (per-stage) linear terms: the O(N) gains
    equal re-solving every tail problem one by one."""
    rng = np.random.default_rng(11)
    N = 24
    dyn = LinearDynamics(np.eye(2) + 0.05 * rng.normal(size=(N, 2, 2)),
                         0.1 * np.eye(2) + 0.05 * rng.normal(size=(N, 2, 2)))
    base = reaching_cost([1.0, 1.0], 0.1)
    J1 = QuadraticCost(0.1 * np.eye(2), rng.normal(size=(N, 2)), base.R, rng.normal(size=(N, 2)), base.QN, base.qN)
    J0 = QuadraticCost(0.1 * np.eye(2), rng.normal(size=(N, 2)), base.R, rng.normal(size=(N, 2)), base.QN, -base.qN)
    schedule = linear_alpha_schedule(0.5, 3.0)
    x0 = np.array([0.3, -0.2])
    xs, us, _ = receding_horizon(dyn, J1, J0, x0, N, schedule, every=every)
    x, naive = x0, []
    for start in range(0, N, every):
        rest = N - start
        plan = legible_trajectory(dyn.stages(start, rest), J1.stages(start, rest), J0.stages(start, rest), x, rest,
                                  schedule(start / N))
        naive.extend(plan.us[:min(every, rest)])
        x = plan.xs[min(every, rest)]
    np.testing.assert_allclose(us, np.array(naive), atol=1e-9)
    np.testing.assert_allclose(xs[-1], x, atol=1e-9)


SMALL_DT, SMALL_N = 0.1, 10
SMALL_DYN = leg.single_integrator(2, SMALL_DT)
SMALL_G0, SMALL_G1 = (-1.0, 1.0), (1.0, 1.0)
SMALL_J0, SMALL_J1 = leg.reaching_cost(SMALL_G0, SMALL_DT), leg.reaching_cost(SMALL_G1, SMALL_DT)


def test_receding_horizon_without_a_shared_quadratic_part_is_refused_before_allocating():
    rng = np.random.default_rng(0)
    dyn, A0, A1, x0 = leg.random_lq_hypotheses(rng, 2, 2, 20_000)
    with pytest.raises(ValueError, match="replan less often"):
        leg.receding_horizon(dyn, A1, A0, x0, 20_000, lambda s: 1.0, every=1)


CASES = [
    # legible trajectories
    (leg.legible_trajectory, (SMALL_DYN, SMALL_J1, SMALL_J0, X0, SMALL_N, np.nan), {}, ValueError, "alpha must be a finite"),
    (leg.legible_trajectory, (SMALL_DYN, SMALL_J1, SMALL_J0, X0, SMALL_N, 0.0), {}, ValueError, "unbounded"),
    (leg.legible_trajectory, (SMALL_DYN, SMALL_J1, [SMALL_J0, SMALL_J0], X0, SMALL_N, 1.0), dict(weights=[1.0, -1.0]), ValueError,
     "weights must be 2 finite non-negative"),
    (leg.receding_horizon, (SMALL_DYN, SMALL_J1, SMALL_J0, [np.nan, 0.0], SMALL_N, lambda s: 1.0), {}, ValueError,
     "x0 must be a finite vector"),
    (leg.receding_horizon, (SMALL_DYN, SMALL_J1, SMALL_J0, X0, SMALL_N, 1.0), {}, ValueError, "alpha_of_s must be a function"),
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
