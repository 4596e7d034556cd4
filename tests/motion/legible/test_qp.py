"""The multi-distractor QP: one distractor equals the weighted LQR, several meet their constraints and its
Lagrangian, the endpoint matches a direct cvxpy model, the sparse form equals the dense one; bad inputs
(a table)."""

import cvxpy as cp
import numpy as np
import pytest

from mutual.motion import legible as leg
from mutual.motion.legible import double_integrator, legible_trajectory, qp, reaching_cost, single_integrator, solve
from mutual.motion.legible import multigoal as mg
from mutual.motion.legible.qp import multi_distractor_qp, receding_horizon_qp


DT, N = 0.01, 100
G0, G1 = np.array([-1.0, 1.0]), np.array([1.0, 1.0])
X0 = np.zeros(2)


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


SMALL_DT, SMALL_N = 0.1, 10
SMALL_DYN = leg.single_integrator(2, SMALL_DT)
SMALL_J0, SMALL_J1 = leg.reaching_cost([-1.0, 1.0], SMALL_DT), leg.reaching_cost([1.0, 1.0], SMALL_DT)


CASES = [
    # several distractors
    (qp.multi_distractor_qp, (SMALL_DYN, SMALL_J1, [], X0, SMALL_N, -1.0), {}, ValueError, "at least one hypothesis"),
    (qp.multi_distractor_qp, (SMALL_DYN, SMALL_J1, [SMALL_J0], [np.nan, 0.0], SMALL_N, -1.0), {}, ValueError, "x0 must be a finite"),
    (qp.multi_distractor_qp, (SMALL_DYN, SMALL_J1, [SMALL_J0], X0, SMALL_N, -1.0), dict(formulation="banded"), ValueError,
     "formulation must be"),
    (qp.multi_distractor_qp, (SMALL_DYN, leg.reaching_cost([0.0, 1.0], SMALL_DT), [SMALL_J0, SMALL_J1], X0, SMALL_N, -100.0), {}, ValueError,
     "infeasible"),
    (qp.multi_distractor_qp, (SMALL_DYN, SMALL_J1, [SMALL_J0], X0, SMALL_N, [-1.0, -1.0]), {}, ValueError, "one per distractor"),
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


# ---- the active set for affine bounds (Figure 6.3's solver) against Clarabel ----------------------------------

AS_DT, AS_N = 0.2, 40


def _random_problem(rng, dyn):
    goals = rng.uniform(-3, 3, size=(4, 2)) + [0, 4]
    pad = np.zeros(dyn.n - 2)
    costs = [reaching_cost(np.concatenate([g, pad]), AS_DT, m=dyn.m) for g in goals]
    x0 = np.zeros(dyn.n)
    # bounds between the plain optimum's values and a little stricter, so that some bind and some do not
    plain = multi_distractor_qp(dyn, costs[0], costs[1:], x0, AS_N, 1e6, solver="active-set")
    gaps = np.array([costs[0].value(plain[0], plain[1]) - J.value(plain[0], plain[1]) for J in costs[1:]])
    return costs, x0, gaps - rng.uniform(-0.5, 1.5, size=3)


@pytest.mark.parametrize("seed", range(6))
def test_active_set_solves_the_qp_clarabel_solves(seed):
    rng = np.random.default_rng(seed)
    for dyn in (single_integrator(2, AS_DT), double_integrator(2, AS_DT)):
        costs, x0, etas = _random_problem(rng, dyn)
        try:
            ref = multi_distractor_qp(dyn, costs[0], costs[1:], x0, AS_N, etas)
        except ValueError as err:
            with pytest.raises(ValueError, match="infeasible"):
                multi_distractor_qp(dyn, costs[0], costs[1:], x0, AS_N, etas, solver="active-set")
            assert "infeasible" in str(err)
            continue
        xs, us, lam = multi_distractor_qp(dyn, costs[0], costs[1:], x0, AS_N, etas, solver="active-set")
        scale = np.abs(ref[1]).max()
        np.testing.assert_allclose(us, ref[1], atol=1e-6 * scale)
        np.testing.assert_allclose(xs, ref[0], atol=1e-6 * max(1.0, np.abs(ref[0]).max()))
        np.testing.assert_allclose(lam, np.clip(ref[2], 0, None), atol=1e-5 * max(1.0, np.abs(ref[2]).max()))


def test_active_set_refuses_what_it_cannot_solve():
    dyn = single_integrator(2, AS_DT)
    J1, J0 = reaching_cost([1.0, 1.0], AS_DT), reaching_cost([-1.0, 1.0], AS_DT, effort_weight=0.5)
    with pytest.raises(ValueError, match="needs affine constraints"):
        multi_distractor_qp(dyn, J1, [J0], np.zeros(2), AS_N, -1.0, solver="active-set")
    goals = mg.row_goals()
    costs = [reaching_cost(g, AS_DT) for g in goals]
    with pytest.raises(ValueError, match="infeasible"):          # the centre cannot beat both neighbours by 5
        multi_distractor_qp(dyn, costs[2], costs[:2] + costs[3:], np.zeros(2), AS_N, -5.0, solver="active-set")


def test_receding_qp_takes_one_bound_per_distractor():
    goals = mg.row_goals()
    costs = [reaching_cost(g, AS_DT) for g in goals]
    dyn = single_integrator(2, AS_DT)
    etas = mg.side_bounds(goals, 1, 0.5, -0.25)
    a = receding_horizon_qp(dyn, costs[1], [costs[0]] + costs[2:], np.zeros(2), AS_N, lambda s: etas * (1 - s))
    b = receding_horizon_qp(dyn, costs[1], [costs[0]] + costs[2:], np.zeros(2), AS_N, lambda s: etas * (1 - s),
                            solver="active-set")
    np.testing.assert_allclose(a[0], b[0], atol=1e-6)
