"""Malformed inputs to chapter 6's public functions (issue 13): each raises a ValueError whose
message names the argument and the reason, never a NaN or a silently different answer."""

import numpy as np
import pytest

from mutual.motion import observer
from mutual.motion import legible as leg
from mutual.motion.legible import anticipation, dragan, explore as explore_legibility, path_measures, qp
from mutual.motion.legible.lqr import solve_lq

DT, N = 0.1, 10
DYN = leg.single_integrator(2, DT)
J0, J1 = leg.reaching_cost([-1.0, 1.0], DT), leg.reaching_cost([1.0, 1.0], DT)
X0 = np.zeros(2)
US = np.ones((N, 2))
NAN_US = US.copy()
NAN_US[3, 1] = np.nan
INF_US = US.copy()
INF_US[0, 0] = np.inf
GOALS = np.array([[-1.0, 1.0], [1.0, 1.0]])
XS = np.linspace([0.0, 0.0], [1.0, 1.0], N + 1)
NAN_XS = XS.copy()
NAN_XS[4, 0] = np.nan
I2 = np.eye(2)
SKEW_R = np.array([[1.0, 5.0], [-5.0, 1.0]])


def lq(**kw):
    args = dict(A=I2, B=DT * I2, Q=np.zeros((2, 2)), R=I2, x0=X0, N=N, QN=I2, qN=np.zeros(2))
    args.update(kw)
    return solve_lq(**args)


CASES = [
    # the LQ solver
    (lq, (), dict(R=SKEW_R), ValueError, "R is not symmetric"),
    (lq, (), dict(R=SKEW_R, backend="jax"), ValueError, "R is not symmetric"),
    (lq, (), dict(Q=np.array([[0.0, 1.0], [0.0, 0.0]])), ValueError, "Q is not symmetric"),
    (lq, (), dict(QN=np.array([[1.0, 2.0], [0.0, 1.0]])), ValueError, "QN is not symmetric"),
    (lq, (), dict(backend="torch"), ValueError, "backend must be"),
    (lq, (), dict(N=2.5), ValueError, "N must be a positive integer"),
    (lq, (), dict(x0=np.array([np.nan, 0.0])), ValueError, "x0 contains non-finite"),
    (lq, (), dict(A=np.array([[1.0, np.inf], [0.0, 1.0]])), ValueError, "A contains non-finite"),
    (lq, (), dict(R=0.001 * I2, QN=-10 * I2, backend="jax"), ValueError, "unbounded LQ problem"),
    # costs and dynamics
    (leg.QuadraticCost, (np.eye(2), np.zeros(2), SKEW_R, np.zeros(2), I2, np.zeros(2)), {}, ValueError,
     "cost field R is not symmetric"),
    (leg.QuadraticCost, (np.full((2, 2), np.nan), np.zeros(2), I2, np.zeros(2), I2, np.zeros(2)), {}, ValueError,
     "cost field Q contains non-finite"),
    (leg.LinearDynamics, (np.array([[1.0, np.nan], [0.0, 1.0]]), I2), {}, ValueError, "dynamics A contains non-finite"),
    (leg.reaching_cost, ([1.0, 1.0],), dict(dt=np.inf), ValueError, "dt and effort_weight must be positive"),
    (leg.single_integrator, (0,), {}, ValueError, "dim must be a positive integer"),
    (leg.double_integrator, (2, -0.1), {}, ValueError, "dt must be a positive finite number"),
    (J1.value, (XS, NAN_US), {}, ValueError, "us contains non-finite"),
    # legible trajectories
    (leg.legible_trajectory, (DYN, J1, J0, X0, N, np.nan), {}, ValueError, "alpha must be a finite"),
    (leg.legible_trajectory, (DYN, J1, J0, X0, N, 0.0), {}, ValueError, "unbounded"),
    (leg.legible_trajectory, (DYN, J1, [J0, J0], X0, N, 1.0), dict(weights=[1.0, -1.0]), ValueError,
     "weights must be 2 finite non-negative"),
    (leg.solve, (DYN, leg.reaching_cost([1.0, 1.0, 1.0], DT), X0, N), {}, ValueError, "the cost is for n = 3"),
    (leg.solve, (DYN, J1, X0, N), dict(backend="jax"), None, None),           # a valid call, for contrast
    (leg.receding_horizon, (DYN, J1, J0, [np.nan, 0.0], N, lambda s: 1.0), {}, ValueError,
     "x0 must be a finite vector"),
    (leg.receding_horizon, (DYN, J1, J0, X0, N, 1.0), {}, ValueError, "alpha_of_s must be a function"),
    (path_measures.time_to_reach, (NAN_XS, 0.5, DT), {}, ValueError, "xs must be a finite"),
    # the Boltzmann observer
    (observer.log_likelihood_ratio, (DYN, J0, J1, X0, NAN_US), {}, ValueError, "us contains non-finite"),
    (observer.log_likelihood_ratio, (DYN, J0, J1, X0, INF_US), {}, ValueError, "us contains non-finite"),
    (observer.log_likelihood_ratio, (DYN, J0, J1, X0, np.ones((N, 3))), {}, ValueError, "us must be an (N, 2)"),
    (observer.log_likelihood_ratio, (DYN, J0, J1, [0.0, np.nan], US), {}, ValueError, "x0 must be a finite vector"),
    (observer.log_boltzmann_prefix, (DYN, J0, X0, NAN_US), {}, ValueError, "us contains non-finite"),
    (observer.posterior_over_time, (DYN, [J0], X0, US), {}, ValueError, "at least two hypotheses"),
    (observer.posterior_over_time, (DYN, [J0, J1], X0, US), dict(prior=[0.5, -0.5]), ValueError,
     "prior must be 2 positive"),
    (observer.likelihood_ratio_minimiser, (DYN, J0, J1, X0, N), dict(alpha=np.inf), ValueError,
     "alpha must be a finite"),
    (observer.sample_boltzmann, (DYN, J0, X0, N, 0, np.random.default_rng(0)), {}, ValueError,
     "size must be a positive integer"),
    (observer.batch_costs, (DYN, J0, X0, NAN_US[None]), {}, ValueError, "us contains non-finite"),
    # several distractors
    (qp.multi_distractor_qp, (DYN, J1, [], X0, N, -1.0), {}, ValueError, "at least one hypothesis"),
    (qp.multi_distractor_qp, (DYN, J1, [J0], [np.nan, 0.0], N, -1.0), {}, ValueError, "x0 must be a finite"),
    (qp.multi_distractor_qp, (DYN, J1, [J0], X0, N, -1.0), dict(formulation="banded"), ValueError,
     "formulation must be"),
    (qp.multi_distractor_qp, (DYN, leg.reaching_cost([0.0, 1.0], DT), [J0, J1], X0, N, -100.0), {}, ValueError,
     "infeasible"),
    (qp.multi_distractor_qp, (DYN, J1, [J0], X0, N, [-1.0, -1.0]), {}, ValueError, "one per distractor"),
    # Dragan and Srinivasa
    (dragan.legibility_score, (NAN_XS, GOALS, 1), {}, ValueError, "xs contains non-finite"),
    (dragan.legibility_score, (np.zeros((N + 1, 3)), GOALS, 1), {}, ValueError, "xs must be a (N+1 >= 2, 2)"),
    (dragan.legibility_score, (XS, GOALS, 1.5), {}, ValueError, "goal_index must index goals"),
    (dragan.goal_posterior, ([np.nan, 0.0], X0, GOALS), {}, ValueError, "points must be finite"),
    (dragan.trajectory_cost, (np.zeros((1, 2)),), {}, ValueError, "xs must be a"),
    (dragan.optimise_legibility, ([np.nan, 0.0], GOALS, 1), {}, ValueError, "start must be finite"),
    (dragan.optimise_legibility, ([1.0, 1.0], GOALS, 1), {}, ValueError, "coincides with the chosen goal"),
    (dragan.optimise_legibility, (X0, GOALS, 1), dict(beta=np.nan), ValueError, "not finite or below"),
    (dragan.optimise_legibility, (X0, GOALS, 1), dict(beta_ratio=0.5), ValueError, "beta_ratio must be"),
    (dragan.optimise_legibility, (X0, GOALS, 1), dict(tol=-1.0), ValueError, "tol must be"),
    (dragan.optimise_legibility, (X0, GOALS, 1), dict(max_iter=-1), ValueError, "max_iter must be"),
    (dragan.gradient_linear_structure, (XS, GOALS, 1), dict(eps=0.0), ValueError, "eps must be a positive"),
    # anticipation and Explore
    (anticipation.weighted_evidence_optimum, (DYN, J1, J0, X0, N), dict(beta=0.0), ValueError, "beta must be"),
    (explore_legibility.legibility_view, (), dict(alpha=-1.0), ValueError, "alpha must be a positive"),
    (explore_legibility.legibility_view, (), dict(n_goals=2, true_goal=5), ValueError, "true_goal must index"),
    (explore_legibility.legibility_view, (), dict(strictness=1.5), ValueError, "strictness must be"),
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


def test_non_symmetric_r_is_not_silently_another_problem():
    """R = [[1, 5], [-5, 1]] has the quadratic form of I; we refuse it rather than solve a different
    problem, and the symmetric part gives the same answer as I."""
    with pytest.raises(ValueError, match="pass \\(R \\+ R'\\)/2"):
        lq(R=SKEW_R)
    np.testing.assert_allclose(lq(R=0.5 * (SKEW_R + SKEW_R.T)).us, lq(R=I2).us, atol=1e-14)
