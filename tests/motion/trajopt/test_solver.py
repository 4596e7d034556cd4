"""iLQR against the exact Riccati solution (chapter 6's solver), a closed form, L-BFGS and second-order DDP,
and its own failure modes (unbounded objectives, far initial guesses, divergence); batches equal one
solve at a time; bad inputs (a table)."""

import jax.numpy as jnp
import numpy as np
import pytest
from scipy.optimize import minimize

from mutual.motion.evident import safety as es
from mutual.motion.legible.lqr import solve_lq
from mutual.motion.trajopt import (ILQRError, ilqr, ilqr_batch, iteration_flops, rollout, solve_lbfgs_jit,
                                   trajectory_cost, trajectory_cost_grad)
from mutual.motion.trajopt.multistart import MultiStart


def _random_lq(seed=0, n=4, m=2, N=30):
    rng = np.random.default_rng(seed)
    A = np.eye(n) + 0.1 * rng.normal(size=(n, n))
    B = rng.normal(size=(n, m))
    Q = np.diag(rng.uniform(0.5, 2, n))
    R = 0.3 * np.eye(m)
    QN, q, qN, x0 = 5 * np.eye(n), rng.normal(size=n), rng.normal(size=n), rng.normal(size=n)
    return A, B, Q, R, QN, q, qN, x0, N


def _lq_dynamics(x, u, p):
    return p["A"] @ x + p["B"] @ u


def _lq_running(x, u, p):
    return 0.5 * x @ p["Q"] @ x + p["q"] @ x + 0.5 * u @ p["R"] @ u


def _lq_terminal(x, p):
    return 0.5 * x @ p["QN"] @ x + p["qN"] @ x


def _lq_ilqr(A, B, Q, R, QN, q, qN, x0, N):
    """iLQR on the LQ problem, its matrices passed as traced params: problems of one shape share one program."""
    params = dict(A=A, B=B, Q=Q, R=R, QN=QN, q=q, qN=qN)
    return ilqr(_lq_dynamics, _lq_running, _lq_terminal, x0, np.zeros((N, B.shape[1])), params)


def test_lq_problem_converges_in_one_step_to_the_riccati_solution():
    A, B, Q, R, QN, q, qN, x0, N = _random_lq()
    result = _lq_ilqr(A, B, Q, R, QN, q, qN, x0, N)
    exact = solve_lq(A, B, Q, R, x0, N, q=q, QN=QN, qN=qN)
    assert result.iterations <= 2
    np.testing.assert_allclose(result.us, exact.us, atol=1e-9)
    np.testing.assert_allclose(result.xs, exact.xs, atol=1e-9)
    assert result.cost == pytest.approx(exact.cost, rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(result.K, exact.K, atol=1e-8)  # the feedback gains of the Riccati pass


@pytest.mark.parametrize("m", [3, 6])  # Q_uu factorised by unrolled arithmetic (m <= 4) and by LAPACK
def test_lq_problems_with_more_controls_match_the_riccati_solution(m):
    A, B, Q, R, QN, q, qN, x0, N = _random_lq(seed=4, n=7, m=m, N=15)
    result = _lq_ilqr(A, B, Q, R, QN, q, qN, x0, N)
    exact = solve_lq(A, B, Q, R, x0, N, q=q, QN=QN, qN=qN)
    np.testing.assert_allclose(result.us, exact.us, atol=1e-9)
    np.testing.assert_allclose(result.K, exact.K, atol=1e-8)


def test_indefinite_but_bounded_lq_problem_is_solved_exactly():
    """A negative state weight (as in (1 + alpha) J1 - J0) that the control cost still dominates."""
    A, B, Q, R, QN, q, qN, x0, N = _random_lq(seed=1, N=10)  # bounded up to N = 15 (Riccati; unbounded from 16)
    Q = -0.02 * np.eye(4)
    exact = solve_lq(A, B, Q, R, x0, N, q=q, QN=QN, qN=qN)
    result = _lq_ilqr(A, B, Q, R, QN, q, qN, x0, N)
    np.testing.assert_allclose(result.us, exact.us, atol=1e-9)


def test_unbounded_lq_problem_is_reported_as_the_riccati_solver_does():
    A, B, Q, R, QN, q, qN, x0, N = _random_lq(seed=2)
    Q = -2.0 * np.eye(4)  # rewards running away faster than controls cost
    with pytest.raises(ValueError, match="unbounded"):
        solve_lq(A, B, Q, R, x0, N, q=q, QN=QN, qN=qN)
    with pytest.raises(ILQRError, match="unbounded"):
        _lq_ilqr(A, B, Q, R, QN, q, qN, x0, N)


def test_objective_unbounded_in_the_controls_is_reported():
    """u = 0 is stationary for -|u|^2 + |x_N|^2 but a saddle, whose negative curvature shows only through the
    backward recursion: iLQR must not return it; from u = 1 it finds the objective unbounded."""
    def dynamics(x, u, params):
        return x + u

    def running(x, u, params):
        return -jnp.sum(u ** 2)

    def terminal(x, params):
        return jnp.sum(x ** 2)

    with pytest.raises(ILQRError, match="not a local minimum|unbounded"):
        ilqr(dynamics, running, terminal, np.zeros(2), np.zeros((5, 2)))
    with pytest.raises(ILQRError, match="unbounded"):
        ilqr(dynamics, running, terminal, np.zeros(2), np.ones((5, 2)))


def _pendulum():
    dt = 0.05

    def dynamics(x, u, params):
        return jnp.stack([x[0] + dt * x[1], x[1] + dt * (-9.81 * jnp.sin(x[0]) + u[0])])

    def running(x, u, params):
        return dt * (0.1 * x @ x + params * u @ u)

    def terminal(x, params):
        return 50.0 * ((x[0] - np.pi) ** 2 + x[1] ** 2)

    return dynamics, running, terminal


def test_nonlinear_optimum_is_stationary_and_no_better_by_lbfgs():
    """Pendulum swing-up: iLQR's controls zero the autodiff gradient and L-BFGS cannot improve them."""
    dyn, run, term = _pendulum()
    x0, us0 = np.zeros(2), np.full((60, 1), 0.1)
    result = ilqr(dyn, run, term, x0, us0, 0.01)
    cost, grad = trajectory_cost_grad(dyn, run, term, x0, result.us, 0.01)
    assert cost == pytest.approx(result.cost, rel=1e-12)
    assert np.abs(grad).max() < 1e-6 * (1 + abs(cost))

    def fun(flat):
        c, g = trajectory_cost_grad(dyn, run, term, x0, flat.reshape(-1, 1), 0.01)
        return c, g.ravel()

    polished = minimize(fun, result.us.ravel(), jac=True, method="L-BFGS-B")
    assert polished.fun >= result.cost - 1e-9 * abs(result.cost)


def test_second_order_ddp_finds_the_same_optimum():
    dyn, run, term = _pendulum()
    x0, us0 = np.zeros(2), np.full((60, 1), 0.1)
    first = ilqr(dyn, run, term, x0, us0, 0.01)
    second = ilqr(dyn, run, term, x0, us0, 0.01, second_order=True)
    assert second.cost == pytest.approx(first.cost, rel=1e-10)
    np.testing.assert_allclose(second.us, first.us, atol=1e-4)  # a flat valley: weak control cost


def test_params_are_traced_not_baked_in():
    dyn, run, term = _pendulum()
    x0, us = np.zeros(2), np.full((60, 1), 0.3)
    low, high = trajectory_cost(dyn, run, term, x0, us, 0.01), trajectory_cost(dyn, run, term, x0, us, 1.0)
    assert high - low == pytest.approx(0.99 * 0.05 * 60 * 0.09, rel=1e-9)


def test_rollout_matches_a_numpy_loop():
    dyn, _, _ = _pendulum()
    us = np.random.default_rng(3).normal(size=(20, 1))
    xs = [np.array([0.3, -0.2])]
    for u in us:
        x = xs[-1]
        xs.append(np.array([x[0] + 0.05 * x[1], x[1] + 0.05 * (-9.81 * np.sin(x[0]) + u[0])]))
    np.testing.assert_allclose(rollout(dyn, xs[0], us), np.array(xs), atol=1e-12)


def test_bad_inputs_are_named():
    dyn, run, term = _pendulum()
    with pytest.raises(ValueError, match="us must have shape"):
        ilqr(dyn, run, term, np.zeros(2), np.zeros(5))
    with pytest.raises(ValueError, match="x0 must be a state vector"):
        ilqr(dyn, run, term, np.zeros((2, 1)), np.zeros((5, 1)))
    with pytest.raises(ValueError, match="dynamics must map"):
        ilqr(lambda x, u, p: x[:1], run, term, np.zeros(2), np.zeros((5, 1)), 0.01)
    with pytest.raises(ValueError, match="running_cost must return a scalar"):
        ilqr(dyn, lambda x, u, p: x, term, np.zeros(2), np.zeros((5, 1)), 0.01)
    with pytest.raises(ValueError, match="max_iter"):
        ilqr(dyn, run, term, np.zeros(2), np.zeros((5, 1)), 0.01, max_iter=0)


@pytest.mark.parametrize("scale", [1e-6, 1e6, 1e4])
@pytest.mark.parametrize("figure", ["7.1", "7.2"])
def test_scaled_objectives_give_the_same_optimum(figure, scale):
    """Multiplying the objective by a constant changes neither the optimum nor the verdict."""
    task, w0, w1 = es.figure_scenario(figure, steps=30)
    for name, w in es.hypothesis_set(w0, w1).items():
        plain = es.solve(task, w)
        scaled = es.solve(task, scale * w)
        assert scaled.cost / scale == pytest.approx(plain.cost, rel=1e-9, abs=1e-9 * abs(plain.magnitude)), name
        np.testing.assert_allclose(scaled.us, plain.us, atol=1e-6)


@pytest.mark.parametrize("start", [1e8, -1e8, 1e3])
def test_far_initial_guess_is_not_mistaken_for_a_solution(start):
    """From u = 1e8 the Fig. 7.1 problem must not 'converge' after 0 iterations (it once stopped there at cost 2e19)."""
    task, w0, w1 = es.figure_scenario("7.1", steps=30)
    exact = es.solve(task, w1)
    far = es.solve(task, w1, np.full((30, 2), start))
    assert far.iterations >= 1
    assert far.cost == pytest.approx(exact.cost, rel=1e-9)
    np.testing.assert_allclose(far.us, exact.us, atol=1e-6)


def test_far_initial_guess_on_the_nonlinear_problem_still_converges_to_a_minimum():
    task, w0, w1 = es.figure_scenario("7.2", steps=30)
    r = es.solve(task, w0, np.full((30, 1), 50.0))
    value, grad = es.cost_gradient(task, w0, r.us)
    assert np.abs(grad).max() <= 1e-6 * r.magnitude
    assert r.cost < es.cost(task, w0, np.full((30, 1), 50.0))


def test_divergence_is_relative_to_the_start_not_an_absolute_bound():
    """An unbounded objective is still reported whatever its scale; a bounded one never is."""
    task, w0, w1 = es.figure_scenario("7.1", steps=30)
    for scale in (1e-6, 1.0, 1e6):
        with pytest.raises(ILQRError, match="unbounded"):
            es.solve(task, scale * es.legible_weights(w1, w0, 0.02))


def test_an_exactly_zero_cost_optimum_converges():
    """No scale of its own (M = 0): the floor eps c keeps the tests meaningful."""
    task, w0, _ = es.figure_scenario("6.1", steps=20)
    r = es.solve(task, w0)
    assert abs(r.cost) < 1e-20
    np.testing.assert_allclose(r.us, 0.0, atol=1e-8)


def test_gauss_newton_ddp_and_auto_agree_on_the_dubins_optima():
    task, w0, w1 = es.figure_scenario("7.2", steps=30)
    for name, w in es.hypothesis_set(w0, w1).items():
        costs = [es.solve(task, w, second_order=order).cost for order in (False, True, "auto")]
        assert max(costs) - min(costs) <= 1e-8 * abs(costs[0]), name


def test_batch_equals_one_at_a_time():
    task, w0, w1 = es.figure_scenario("7.2", steps=30)
    alphas = [0.5, 1.0, 2.0, 0.02]
    weights = [es.legible_weights(w1, w0, a) for a in alphas]
    batch = es.solve_batch(task, weights)
    for w, r, err in zip(weights, batch.results, batch.errors):
        try:
            single = es.solve(task, w, second_order=False)  # the batch's default (Gauss-Newton)
        except ILQRError:
            assert r is None and err
            continue
        assert r.cost == pytest.approx(single.cost, rel=1e-12)
        np.testing.assert_allclose(r.us, single.us, atol=1e-10)
    assert "problems" in repr(batch)


def test_a_shrinking_batch_gives_each_member_its_own_passes():
    """Members that stop early leave the batch (gathered into ever smaller batches): each member
    still takes exactly the passes, and reaches the cost, that it takes alone."""
    task, w0, w1 = es.figure_scenario("7.2", steps=30)
    alphas = np.linspace(0.3, 3.0, 20)  # legible solves of very different lengths
    weights = [es.legible_weights(w1, w0, a) for a in alphas]
    batch = es.solve_batch(task, weights)
    passes = []
    for w, r in zip(weights, batch.results):
        single = es.solve(task, w, second_order=False)
        assert r.passes == single.passes and r.iterations == single.iterations
        assert r.cost == pytest.approx(single.cost, rel=1e-12)
        passes.append(r.passes)
    assert max(passes) > 2 * min(passes)  # the batch really had to shrink


def test_target_stops_at_the_first_step_that_reaches_it():
    task, w0, w1 = es.figure_scenario("7.2", steps=30)
    full = es.solve(task, w1, grad_tol=1e-9)
    target = full.cost + 1e-6 * abs(full.cost)
    early = es.solve(task, w1, target=target)
    assert early.cost <= target and early.costs[-2] > target
    assert early.iterations < full.iterations
    np.testing.assert_allclose(early.costs, full.costs[:early.iterations + 1], rtol=1e-12)


def test_multistart_reports_disagreeing_runs():
    """The legible Fig. 7.2 problem has two routes around the hazard: starts turning either way find both."""
    task, w0, w1 = es.figure_scenario("7.2", steps=30)
    multi = es.best_of_starts(task, es.legible_weights(w1, w0, 0.5), turn_rates=(2.0, -2.0, 0.0), second_order=("auto",))
    best, converged = multi
    assert converged == multi.converged >= 2
    assert best.cost == pytest.approx(np.nanmin(multi.costs))
    assert multi.local_minima == (len(multi.minima) > 1)
    costs = multi.costs[np.isfinite(multi.costs)]
    assert multi.local_minima == bool(costs.max() - costs.min() > 1e-6 * best.magnitude)
    convex, v0, v1 = es.figure_scenario("7.1", steps=20)  # LQ: one minimum, every start agrees
    agree = es.best_of_starts(convex, v1, turn_rates=(0.0, 1.0, -3.0), second_order=("auto", False))
    assert agree.converged == 6 and not agree.local_minima and "agree" in repr(agree)


def test_result_repr_is_short():
    task, w0, w1 = es.figure_scenario("7.1", steps=30)  # the scaled objectives' problem: compiled once
    text = repr(es.solve(task, w0))
    assert text.startswith("ILQRResult(cost=") and len(text) < 150 and "array" not in text


def test_jitted_lbfgs_baseline_reaches_the_same_cost():
    task, w0, w1 = es.figure_scenario("7.2", steps=30)
    r = es.solve(task, w1)
    dyn, run, term, x0, params = es.problem(task, w1)
    us, cost, its = solve_lbfgs_jit(dyn, run, term, x0, task.zero_controls(), params, target=r.cost + 1e-9 * abs(r.cost))
    assert cost <= r.cost + 1e-9 * abs(r.cost) and its > 1


def test_legible_iteration_costs_at_most_the_sum_of_the_hypotheses():
    """Corollary 6.4.2.1 counted by XLA: evaluating both hypotheses' costs adds far less than a second iteration."""
    task, w0, w1 = es.figure_scenario("7.2", steps=20)
    plain = iteration_flops(*es.problem(task, w1)[:4], task.zero_controls(), es.problem(task, w1)[4])
    dyn, run, term, x0, p = es.literal_legible_problem(task, w0, w1, 0.5)
    legible = iteration_flops(dyn, run, term, x0, task.zero_controls(), p)
    assert plain < legible <= 2 * plain


def dyn(x, u, p):
    return x + 0.1 * u


def run(x, u, p):
    return jnp.sum(u ** 2) + jnp.sum(x ** 2)


def term(x, p):
    return jnp.sum(x ** 2)


X0, US = np.ones(2), np.zeros((5, 2))


CASES = [
    # ilqr: shapes, values and callables
    (ilqr, (dyn, run, term, X0, np.zeros(5)), {}, ValueError, "us must have shape"),
    (ilqr, (dyn, run, term, np.ones((2, 1)), US), {}, ValueError, "x0 must be a state vector"),
    (ilqr, (dyn, run, term, [np.nan, 0.0], US), {}, ValueError, "x0 must be finite"),
    (ilqr, (dyn, run, term, X0, np.full((5, 2), np.inf)), {}, ValueError, "us must be finite"),
    (ilqr, (dyn, run, term, "ab", US), {}, ValueError, "x0 must be an array of numbers"),
    (ilqr, ("f", run, term, X0, US), {}, ValueError, "dynamics must be callable"),
    (ilqr, (lambda x, u, p: x[:1], run, term, X0, US), {}, ValueError, "dynamics must map"),
    (ilqr, (dyn, lambda x, u, p: x, term, X0, US), {}, ValueError, "running_cost must return a scalar"),
    (ilqr, (dyn, run, lambda x, p: x, X0, US), {}, ValueError, "terminal_cost must return a scalar"),
    (ilqr, (dyn, run, term, X0, US), {"max_iter": 0}, ValueError, "max_iter must be a positive integer"),
    (ilqr, (dyn, run, term, X0, US), {"max_iter": True}, ValueError, "max_iter must be a positive integer"),
    (ilqr, (dyn, run, term, X0, US), {"grad_tol": -1.0}, ValueError, "grad_tol must be a positive finite"),
    (ilqr, (dyn, run, term, X0, US), {"stall_tol": np.nan}, ValueError, "stall_tol must be a positive finite"),
    (ilqr, (dyn, run, term, X0, US), {"divergence_ratio": 0}, ValueError, "divergence_ratio must be a positive"),
    (ilqr, (dyn, run, term, X0, US), {"divergence_bound": -1}, ValueError, "divergence_bound must be None"),
    (ilqr, (dyn, run, term, X0, US), {"second_order": "yes"}, ValueError, "second_order must be"),
    (ilqr, (dyn, run, term, X0, US), {"target": np.inf}, ValueError, "target must be None or a finite number"),
    (ilqr, (dyn, run, term, X0, US), {"target": "low"}, ValueError, "target must be None or a finite number"),
    (ilqr, (dyn, run, term, X0, US, np.array([np.nan])), {}, ValueError, "params must be finite"),
    # ilqr_batch
    (ilqr_batch, (dyn, run, term, X0, US[None]), {}, ValueError, "x0 must have shape (B, n)"),
    (ilqr_batch, (dyn, run, term, np.ones((3, 2)), np.zeros((2, 5, 2))), {}, ValueError, "us must have shape (B, N, m)"),
    (ilqr_batch, (dyn, run, term, np.ones((3, 2)), np.zeros((3, 5, 2)), np.ones(2)), {}, ValueError,
     "leading batch axis"),
    (MultiStart.from_runs, ([None, None], ["a", "b"]), {}, ValueError, "no start converged"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i}-{c[0].__name__}-{c[4][:24]}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase.replace("(", r"\(").replace(")", r"\)")):
        fn(*args, **kwargs)
