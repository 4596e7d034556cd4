"""Chapter 7: the Dubins integrator, the hypothesis costs, and iLQR's optima checked independently."""

import jax
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mutual.motion.evident import evidence, vehicles
from mutual.motion.evident import safety as es
from mutual.supervision.dubins import dubins_step as dubins_step_numpy
from mutual.motion.trajopt import ILQRError
from mutual.motion.legible import single_integrator
from mutual.motion.legible import solve as solve_riccati


def test_dubins_step_integrates_eq_7_5_exactly_for_constant_turn_rates():
    rng = np.random.default_rng(0)
    for x0, u in [(rng.normal(size=3), 1.7), (rng.normal(size=3), 0.0), (rng.normal(size=3), -4.0)]:
        ode = solve_ivp(lambda t, x: [3 * np.cos(x[2]), 3 * np.sin(x[2]), u], (0, 0.3), x0, rtol=1e-12, atol=1e-12)
        with jax.enable_x64(True):
            ours = np.asarray(vehicles.dubins_step(x0, np.array([u]), 0.3))
        np.testing.assert_allclose(ours, ode.y[:, -1], atol=1e-9)


def test_dubins_step_agrees_with_chapter_5s_numpy_integrator():
    rng = np.random.default_rng(1)
    states, controls = rng.normal(size=(20, 3)), rng.normal(size=20)
    with jax.enable_x64(True):
        ours = np.array(jax.vmap(vehicles.dubins_step, in_axes=(0, 0, None))(states, controls[:, None], 0.1))
    theirs = dubins_step_numpy(states, controls, 0.1)
    np.testing.assert_allclose(ours[:, :2], theirs[:, :2], atol=1e-12)
    np.testing.assert_allclose(np.angle(np.exp(1j * ours[:, 2])), theirs[:, 2], atol=1e-12)


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
    task, w0, w1 = es.figure_scenario("7.1", steps=40)
    us = np.random.default_rng(4).normal(size=(40, 2))
    xs = task.x0 + task.dt * np.vstack([np.zeros(2), np.cumsum(us, axis=0)])
    weights = es.hypothesis_set(w0, w1)
    for name, cost in es.lq_hypothesis_costs(task, w0, w1).items():
        assert cost.value(xs, us) == pytest.approx(es.cost(task, weights[name], us), rel=1e-12)


def test_figure_7_1_ilqr_equals_chapter_6_riccati_solution_in_one_step():
    task, w0, w1 = es.figure_scenario("7.1", steps=60)
    results = es.solve_hypotheses(task, w0, w1)
    for name, cost in es.lq_hypothesis_costs(task, w0, w1).items():
        exact = solve_riccati(single_integrator(2, task.dt), cost, task.x0, task.steps)
        assert results[name].iterations <= 2
        np.testing.assert_allclose(results[name].xs, exact.xs, atol=1e-10)
        assert results[name].cost == pytest.approx(cost.value(exact.xs, exact.us), rel=1e-10)


def test_unbounded_legible_objective_is_reported_by_both_solvers():
    """With a tiny alpha the hazard reward (1 + alpha) / alpha a3 beats the effort cost over T = 5."""
    task, w0, w1 = es.figure_scenario("7.1", steps=60)
    alpha = 0.02
    with pytest.raises(ValueError, match="unbounded"):
        solve_riccati(single_integrator(2, task.dt), es.lq_hypothesis_costs(task, w0, w1, alpha)["legible"],
                      task.x0, task.steps)
    with pytest.raises(ILQRError, match="unbounded"):
        es.solve(task, es.legible_weights(w1, w0, alpha))


@pytest.fixture(scope="module")
def dubins():
    task, w0, w1 = es.figure_scenario("7.2")
    return task, w0, w1, es.solve_hypotheses(task, w0, w1)


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


def test_dubins_story_h1_slightly_farther_legible_obviously_farther(dubins):
    task, _, _, results = dubins
    d = {k: evidence.distance_to_point(r.xs, task.hazard, task.dt) for k, r in results.items()}
    assert d["H0"]["integral"] < d["H1"]["integral"] < 1.05 * d["H0"]["integral"]
    assert d["legible"]["integral"] > 1.3 * d["H1"]["integral"]
    assert d["legible"]["min"] > 1.5 * d["H1"]["min"]


def test_distance_to_point_closed_form():
    t = np.linspace(0, 2, 201)
    xs = np.c_[t - 1, np.ones_like(t)]  # the line y = 1 from x = -1 to 1, unit speed
    d = evidence.distance_to_point(xs, [0, 0], dt=0.01)
    assert d["min"] == pytest.approx(1.0)
    assert d["integral"] == pytest.approx(np.arcsinh(1) + np.sqrt(2), rel=1e-5)  # int sqrt(1 + s^2) ds


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


def test_bicycle_step_integrates_the_kinematic_bicycle():
    """One RK4 step against scipy's adaptive integrator (error O(dt^5) per step)."""
    rng = np.random.default_rng(5)
    for _ in range(3):
        x0 = np.r_[rng.normal(size=3), 2 + rng.random()]
        u = np.array([0.4 * rng.normal(), rng.normal()])
        ode = solve_ivp(lambda t, x: [x[3] * np.cos(x[2]), x[3] * np.sin(x[2]), x[3] * np.tan(u[0]) / 1.0, u[1]],
                        (0, 0.04), x0, rtol=1e-12, atol=1e-12)
        with jax.enable_x64(True):
            ours = np.asarray(vehicles.bicycle_step(x0, u, 0.04, 1.0))
        np.testing.assert_allclose(ours, ode.y[:, -1], atol=1e-8)


def test_figure_6_1_uses_the_bicycle():
    task, w0, w1 = es.figure_scenario("6.1", steps=20)
    assert task.x0.shape == (4,) and task.controls == 2
    us = np.zeros((20, 2))
    us[:, 1] = 0.5  # accelerate straight ahead: x = -6 + 3 t + t^2 / 4
    xs = es.rollout(task, us)
    assert xs[-1, 0] == pytest.approx(-6 + 3 * 4 + 0.25 * 16, rel=1e-12)
    assert xs[-1, 3] == pytest.approx(3 + 0.5 * 4)


def test_evidence_rules():
    t = np.linspace(0, 1, 11)
    h0 = np.c_[2 * t - 1, np.full_like(t, 0.2)]  # passes 0.2 from the hazard at the origin at t = 0.5
    far = np.c_[2 * t - 1, 0.2 + np.minimum(t, 1 - t) * 2]  # bends away from the start
    lead = evidence.lead_time(far, h0, [0.0, 0.0], 0.1)
    assert lead["t_close"] == pytest.approx(0.5)
    assert lead["t_separate"] == pytest.approx(0.1)
    assert evidence.lead_time(h0, h0, [0.0, 0.0], 0.1)["lead"] == -np.inf
    assert evidence.close_but_clear(0.5, 0.3) and not evidence.close_but_clear(0.7, 0.3)
    holds, gain, ratio = evidence.obvious_avoidance(far, h0, h0 + [0, 0.01], [0.0, 1.0], 0.1)
    assert not holds and gain < 0  # 'far' bends towards this hazard, so it is not more evident
    holds, gain, ratio = evidence.obvious_avoidance(far, h0, h0 + [0, 0.01], [0.0, -0.5], 0.1)
    assert ratio > 1 and holds == (gain >= 0.25 and ratio >= 1.5)


def test_notebook_reports_every_claim_with_its_computation(executed_notebook):
    claims = executed_notebook("06_evident_safety")
    expected = {"c7-fig71-legible-demonstrates-correction", "c7-fig71-ilqr-equals-riccati", "c7-ilqr-converges",
                "c7-fig72-h1-integral-farther", "c7-fig72-h1-only-slightly", "c7-fig72-legible-obvious",
                "c7-fig72-anticipates-lead-time", "c7-mpc-anticipation-exaggeration", "c7-ilqr-same-complexity",
                "c6-fig61-ignorant-collision", "c6-fig61-h1-avoids-but-close", "c6-fig61-legible-farther",
                "c6-ds-too-slow-on-a-car", "c7-belief-shows-correction", "c7-running-constraints"}
    assert expected <= set(claims)
    for cid in expected:
        assert claims[cid]["computed_by"].startswith("mutual.motion."), cid
        assert claims[cid]["note"].startswith("06_evident_safety"), cid
    assert claims["c7-fig71-ilqr-equals-riccati"]["value"] is True
    assert claims["c7-ilqr-converges"]["value"] is True
    assert claims["c7-running-constraints"]["value"] is True and claims["c7-ilqr-same-complexity"]["value"] is True
    for cid in ("c7-fig71-legible-demonstrates-correction", "c7-fig72-h1-integral-farther", "c6-fig61-ignorant-collision"):
        assert claims[cid]["value"] is True, cid                     # hold by construction, at any size
    for cid in ("c7-fig72-h1-only-slightly", "c7-fig72-legible-obvious", "c7-fig72-anticipates-lead-time",
                "c7-mpc-anticipation-exaggeration", "c6-fig61-h1-avoids-but-close", "c6-fig61-legible-farther",
                "c6-ds-too-slow-on-a-car", "c7-belief-shows-correction"):
        assert set(claims[cid]["scan"]) == {"table", "seeds", "settings", "flips"}, cid


def test_sin_ratio_derivatives_match_the_series():
    """sin(a)/a and its first three derivatives by autodiff (what DDP and the Laplace Hessians use)
    against the term-by-term derivatives of its Taylor series, on both sides of the series switch."""
    import math

    from mutual.motion.evident.vehicles import sin_ratio

    def series(a, n):
        return sum((-1) ** k / math.factorial(2 * k + 1) * math.factorial(2 * k) / math.factorial(2 * k - n)
                   * a ** (2 * k - n) for k in range(40) if 2 * k >= n)

    fs = [sin_ratio]
    for _ in range(3):
        fs.append(jax.grad(fs[-1]))
    with jax.enable_x64(True):
        for a in (0.0, 1e-9, 1e-5, 0.0099, 0.0101, 0.1, 1.0, -0.7, 3.0):
            for n, f in enumerate(fs):
                assert float(f(a)) == pytest.approx(series(a, n), abs=1e-9), (a, n)


# ---- what the thesis leaves open: scans, the batched MPC, and Dragan and Srinivasa on a car -------------------

def test_hazard_feature_orders_the_optima_of_fig_7_1():
    """Comparing exact optima under both costs: J1 = J0 - a3 F forces F(H0) <= F(H1) <= F(legible) (LQ: global)."""
    from mutual.motion.evident import scans
    task, w0, w1 = es.figure_scenario("7.1", steps=40)
    paths = es.solve_hypotheses(task, w0, w1)
    f = {k: scans.hazard_feature(r.xs, task.hazard, task.dt) for k, r in paths.items()}
    assert f["H0"] < f["H1"] < f["legible"]
    xs = np.array([[1.0, 0.0], [0.0, 2.0], [5.0, 5.0]])
    assert scans.hazard_feature(xs, [0.0, 0.0], 0.5) == pytest.approx(0.5 * (1 + 4))


def test_figure_72_scan_solves_both_hazards_for_every_alpha():
    from mutual.motion.evident import scans
    table, paths = scans.figure_72_scan([0.5, 1.0], [[-2.0, 2.0], [2.0, -2.0]], steps=20)
    assert len(table) == 4 and set(table["hazard"]) == {"[-2.0, 2.0]", "[2.0, -2.0]"}
    assert {"obvious", "anticipates", "H1 only slightly", "feature legible"} <= set(table.columns)
    assert set(paths[(2.0, -2.0)]) == {"H0", "H1", 0.5, 1.0}
    same = es.solve(es.figure_scenario("7.2", steps=20)[0], es.figure_scenario("7.2", steps=20)[2])
    np.testing.assert_allclose(paths[(-2.0, 2.0)]["H1"].xs, same.xs)       # the chosen cell is the notebook's solve


def test_figure_61_scan_rows():
    from mutual.motion.evident import scans
    table = scans.figure_61_scan((10.0,), (5.0, 20.0), (0.5,), steps=20)
    assert len(table) == 2 and table["H0 collides"].all()                   # the person stands on H0's course
    assert (table["H1 closest"] > 0).all() and table["error"].eq("").all()


def test_batched_receding_horizon_equals_one_at_a_time():
    from mutual.motion.evident import mpc
    from mutual.motion.legible import linear_alpha_schedule
    task, w0, w1 = es.figure_scenario("7.2", steps=20)
    schedule = linear_alpha_schedule(0.25, 4.0)
    single = mpc.receding_horizon_ilqr(task, w0, w1, schedule, every=5, second_order=False)
    batch = mpc.receding_horizon_ilqr_batch([task, task], w0, w1, [schedule, linear_alpha_schedule(0.5, 4.0)], every=5)
    np.testing.assert_allclose(batch[0]["xs"], single["xs"], atol=1e-6)
    assert batch[0]["replans"] == 4 and not np.allclose(batch[1]["xs"], batch[0]["xs"])
    with pytest.raises(ValueError, match="equally long"):
        mpc.receding_horizon_ilqr_batch([task], w0, w1, [schedule, schedule])


def test_dragan_srinivasa_on_a_car():
    """Their continuations: V_G at the last stage is the terminal cost, dV_G/dx matches a re-solve at a moved
    state (the envelope theorem); ours equals the feature cost of the virtual goal g_R + (g_R - g_L)/alpha."""
    from mutual.motion.evident import dragan_car
    task, goals = dragan_car.two_goal_task(steps=4)
    conts = dragan_car.Continuations(task, goals)
    xs = es.rollout(task, np.full((4, 1), 0.3))
    V, dV = conts(xs)
    a1, a2 = dragan_car.WEIGHTS
    np.testing.assert_allclose(V[:, -1], a1 * ((xs[-1, :2] - goals) ** 2).sum(1), rtol=1e-9)
    eps = 1e-5
    moved = xs.copy()
    moved[1, 0] += eps
    Vm, _ = dragan_car.Continuations(task, goals)(moved)
    np.testing.assert_allclose((Vm[:, 1] - V[:, 1]) / eps, dV[:, 1, 0], rtol=1e-3, atol=1e-3)
    score, grad, posterior = dragan_car.legibility(task, goals, np.full((4, 1), 0.3), conts)
    assert 0 < score < 1 and grad.shape == (4, 1) and posterior[0] == pytest.approx(0.5)
    alpha = 0.5
    ours = dragan_car.solve_ours(task, goals, alpha)
    virtual = es.EvidentSafetyTask(x0=task.x0, goal=goals[1] + (goals[1] - goals[0]) / alpha, horizon=task.horizon, steps=4)
    np.testing.assert_allclose(ours.us, es.solve(virtual, es.hypothesis_weights(alpha * a1, alpha * a2)).us, atol=1e-6)
