"""Evident safety (chapter 7): the hypothesis costs in closed form, the legible cost as their linear
combination, Figure 7.1 by iLQR equal to chapter 6's Riccati solution, stationary Dubins optima that
L-BFGS cannot improve, and the hazard feature's ordering of the optima; bad inputs (a table)."""

import numpy as np
import pytest

from mutual.motion.evident import safety as es
from mutual.motion.legible import single_integrator, solve as solve_riccati
from mutual.motion.trajopt import ILQRError


def test_keep_out_penalty_and_hazard_term_closed_forms():
    states = np.array([[0.0, 0.0], [3.0, 4.0]])
    p = np.array([0.0, 1.0])
    expected = 1 / (1 + 1 / 0.25) + 1 / (1 + 18 / 0.25)
    assert float(es.keep_out_penalty(p, states, 0.5)) == pytest.approx(expected, rel=1e-6)
    assert float(es.keep_out_penalty(p, np.zeros((0, 2)), 0.5)) == 0.0
    assert float(es.hazard_term(p, np.array([3.0, 5.0]))) == pytest.approx(25.0)


def test_legible_cost_is_the_linear_combination_of_the_hypotheses():
    """Eq. (6.15) on the feature cost: (1 + alpha) J1(u) - J0(u) for any controls."""
    for figure in ("7.2", "6.1"):
        task, w0, w1 = es.figure_scenario(figure, steps=30)
        us = np.random.default_rng(2).normal(size=(30, 1))
        J0, J1 = es.cost(task, w0, us), es.cost(task, w1, us)
        legible = es.cost(task, es.legible_weights(w1, w0, 0.7), us)
        assert legible == pytest.approx(1.7 * J1 - J0, rel=1e-12)


def test_lq_form_of_figure_7_1_costs_matches_the_feature_costs():
    """Chapter 6's QuadraticCost (numpy) and our JAX feature cost agree on random controls."""
    task, w0, w1 = es.figure_scenario("7.1", steps=30)
    us = np.random.default_rng(4).normal(size=(30, 2))
    xs = task.x0 + task.dt * np.vstack([np.zeros(2), np.cumsum(us, axis=0)])
    weights = es.hypothesis_set(w0, w1)
    for name, cost in es.lq_hypothesis_costs(task, w0, w1).items():
        assert cost.value(xs, us) == pytest.approx(es.cost(task, weights[name], us), rel=1e-12)


def test_figure_7_1_ilqr_equals_chapter_6_riccati_solution_in_one_step():
    task, w0, w1 = es.figure_scenario("7.1", steps=30)
    results = es.solve_hypotheses(task, w0, w1)
    for name, cost in es.lq_hypothesis_costs(task, w0, w1).items():
        exact = solve_riccati(single_integrator(2, task.dt), cost, task.x0, task.steps)
        assert results[name].iterations <= 2
        np.testing.assert_allclose(results[name].xs, exact.xs, atol=1e-10)
        assert results[name].cost == pytest.approx(cost.value(exact.xs, exact.us), rel=1e-10)


def test_unbounded_legible_objective_is_reported_by_both_solvers():
    """With a tiny alpha the hazard reward (1 + alpha) / alpha a3 beats the effort cost over T = 5."""
    task, w0, w1 = es.figure_scenario("7.1", steps=30)
    alpha = 0.02
    with pytest.raises(ValueError, match="unbounded"):
        solve_riccati(single_integrator(2, task.dt), es.lq_hypothesis_costs(task, w0, w1, alpha)["legible"],
                      task.x0, task.steps)
    with pytest.raises(ILQRError, match="unbounded"):
        es.solve(task, es.legible_weights(w1, w0, alpha))


def test_dubins_optima_have_zero_gradient(dubins):
    task, w0, w1, results = dubins
    weights = es.hypothesis_set(w0, w1)
    for name, r in results.items():
        cost, grad = es.cost_gradient(task, weights[name], r.us)
        assert cost == pytest.approx(r.cost, rel=1e-12)
        assert np.abs(grad).max() < 1e-7 * (1 + abs(cost)), name


def test_lbfgs_finds_nothing_better_near_ilqrs_dubins_optima(dubins):
    task, w0, w1, results = dubins
    weights = es.hypothesis_set(w0, w1)
    for name, r in results.items():
        tol = 1e-8 * (1 + abs(r.cost))
        _, polished, _ = es.solve_lbfgs(task, weights[name], r.us)
        assert polished >= r.cost - tol, name
        us, scratch, _ = es.solve_lbfgs(task, weights[name])  # from rest, like iLQR
        assert scratch >= r.cost - tol, name
        if scratch <= r.cost + 1e-6 * (1 + abs(r.cost)):  # the same optimum, then the same controls
            np.testing.assert_allclose(us, r.us, atol=1e-3)
        rng = np.random.default_rng(3)
        for _ in range(5):  # random nearby controls are never better
            assert es.cost(task, weights[name], r.us + 1e-3 * rng.normal(size=r.us.shape)) > r.cost


def test_task_validation_names_the_argument():
    with pytest.raises(ValueError, match="x0"):
        es.EvidentSafetyTask(x0=[0, 0, 0, 0, 0], goal=[1, 1])
    with pytest.raises(ValueError, match="goal"):
        es.EvidentSafetyTask(x0=[0, 0], goal=[1, 1, 1])
    with pytest.raises(ValueError, match="keep_out"):
        es.EvidentSafetyTask(x0=[0, 0], goal=[1, 1], keep_out=[[0, 0, 0]])
    with pytest.raises(ValueError, match="weights"):
        es.EvidentSafetyTask(x0=[0, 0], goal=[1, 1]).params([1, 2])
    with pytest.raises(ValueError, match="figure"):
        es.figure_scenario("9.9")


def test_figure_6_1_uses_the_bicycle():
    task, w0, w1 = es.figure_scenario("6.1", steps=20)
    assert task.x0.shape == (4,) and task.controls == 2
    us = np.zeros((20, 2))
    us[:, 1] = 0.5  # accelerate straight ahead: x = -6 + 3 t + t^2 / 4
    xs = es.rollout(task, us)
    assert xs[-1, 0] == pytest.approx(-6 + 3 * 4 + 0.25 * 16, rel=1e-12)
    assert xs[-1, 3] == pytest.approx(3 + 0.5 * 4)


def test_hazard_feature_orders_the_optima_of_fig_7_1():
    """Comparing exact optima under both costs: J1 = J0 - a3 F forces F(H0) <= F(H1) <= F(legible) (LQ: global)."""
    from mutual.motion.evident import scans
    task, w0, w1 = es.figure_scenario("7.1", steps=30)
    paths = es.solve_hypotheses(task, w0, w1)
    f = {k: scans.hazard_feature(r.xs, task.hazard, task.dt) for k, r in paths.items()}
    assert f["H0"] < f["H1"] < f["legible"]
    xs = np.array([[1.0, 0.0], [0.0, 2.0], [5.0, 5.0]])
    assert scans.hazard_feature(xs, [0.0, 0.0], 0.5) == pytest.approx(0.5 * (1 + 4))


TASK, W0, W1 = es.figure_scenario("7.1", steps=10)
SMALL = dict(x0=[0.0, 0.0], goal=[1.0, 1.0])


CASES = [
    # evident-safety tasks and solves
    (es.EvidentSafetyTask, (), {"x0": np.zeros(5), "goal": [1, 1]}, ValueError, "x0 must be a planar position"),
    (es.EvidentSafetyTask, (), {"x0": [0, 0], "goal": [1, 1, 1]}, ValueError, "goal must be a planar point"),
    (es.EvidentSafetyTask, (), {**SMALL, "hazard": [np.nan, 0]}, ValueError, "hazard must be finite"),
    (es.EvidentSafetyTask, (), {**SMALL, "keep_out": [[0, 0, 0]]}, ValueError, "keep_out must have shape"),
    (es.EvidentSafetyTask, (), {**SMALL, "radius": 0.0}, ValueError, "radius must be a positive"),
    (es.EvidentSafetyTask, (), {**SMALL, "horizon": np.inf}, ValueError, "horizon must be a positive"),
    (es.EvidentSafetyTask, (), {**SMALL, "wheelbase": -1.0}, ValueError, "wheelbase must be a positive"),
    (es.EvidentSafetyTask, (), {**SMALL, "steps": 0}, ValueError, "steps must be a positive integer"),
    (es.EvidentSafetyTask, (), {**SMALL, "steps": 2.5}, ValueError, "steps must be a positive integer"),
    (TASK.params, ([1.0, 2.0],), {}, ValueError, "weights must be 4 finite numbers"),
    (es.figure_scenario, ("9.9",), {}, ValueError, "figure must be"),
    (es.legible_weights, (W1, W0, np.nan), {}, ValueError, "alpha must be a finite number"),
    (es.solve, (TASK, es.legible_weights(W1, W0, 0.02)), {}, ILQRError, "unbounded"),
    (es.solve_batch, ([TASK, TASK], [W0, W1, W1]), {}, ValueError, "same number of problems"),
    (es.solve_batch, ([], W0), {}, ValueError, "tasks must be an EvidentSafetyTask"),
    (es.best_of_starts, (TASK, W1), {"turn_rates": []}, ValueError, "turn_rates must be a non-empty"),
    (es.alpha_sweep, (TASK, W0, W1, []), {}, ValueError, "alphas must not be empty"),
    (es.lq_hypothesis_costs, (es.figure_scenario("7.2", steps=10)[0], W0, W1), {}, ValueError, "needs x' = u"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i}-{c[0].__name__}-{c[4][:24]}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase.replace("(", r"\(").replace(")", r"\)")):
        fn(*args, **kwargs)
