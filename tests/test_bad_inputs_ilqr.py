"""Bad inputs for iLQR, evident safety and their helpers (issue 13): each case names the argument and
the reason in a ValueError (or, for an objective that has no minimum, an ILQRError)."""

import jax.numpy as jnp
import numpy as np
import pytest

from mutual.motion import animation, belief
from mutual.motion.evident import evidence, explore, mpc
from mutual.motion.evident import safety as es
from mutual.motion.trajopt import ILQRError, ilqr, ilqr_batch
from mutual.motion.trajopt.multistart import MultiStart


def dyn(x, u, p):
    return x + 0.1 * u


def run(x, u, p):
    return jnp.sum(u ** 2) + jnp.sum(x ** 2)


def term(x, p):
    return jnp.sum(x ** 2)


X0, US = np.ones(2), np.zeros((5, 2))
TASK, W0, W1 = es.figure_scenario("7.1", steps=10)
SMALL = dict(x0=[0.0, 0.0], goal=[1.0, 1.0])
PATH = np.c_[np.linspace(0, 1, 11), np.zeros(11)]

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
    (ilqr, (dyn, lambda x, u, p: -jnp.sum(u ** 2), term, X0, US), {}, ILQRError, "unbounded"),
    # ilqr_batch
    (ilqr_batch, (dyn, run, term, X0, US[None]), {}, ValueError, "x0 must have shape (B, n)"),
    (ilqr_batch, (dyn, run, term, np.ones((3, 2)), np.zeros((2, 5, 2))), {}, ValueError, "us must have shape (B, N, m)"),
    (ilqr_batch, (dyn, run, term, np.ones((3, 2)), np.zeros((3, 5, 2)), np.ones(2)), {}, ValueError,
     "leading batch axis"),
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
    (MultiStart.from_runs, ([None, None], ["a", "b"]), {}, ValueError, "no start converged"),
    # evidence measures
    (evidence.distance_to_point, (np.zeros(3), [0, 0], 0.1), {}, ValueError, "xs must have shape"),
    (evidence.distance_to_point, (PATH, [0, 0, 0], 0.1), {}, ValueError, "point must be a finite planar point"),
    (evidence.distance_to_point, (PATH, [0, 0], 0.0), {}, ValueError, "dt must be a positive"),
    (evidence.lead_time, (PATH, PATH[:5], [0, 0], 0.1), {}, ValueError, "same number of knots"),
    # belief, MPC, animation, explore
    (belief.posterior_over_time, (np.zeros((2, 1)), (np.zeros((2, 1)), np.eye(2)), (np.zeros((2, 1)), np.eye(2))),
     {"prior": 0.0}, ValueError, "prior must be a probability"),
    (belief.gaussian_prefix_loglik, (np.zeros((2, 1)), np.zeros((3, 1)), np.eye(2)), {}, ValueError, "same shape"),
    (belief.gaussian_prefix_loglik, (np.zeros((2, 1)), np.zeros((2, 1)), -np.eye(2)), {}, ValueError,
     "not positive definite"),
    (mpc.receding_horizon_ilqr, (TASK, W0, W1, lambda s: 1.0), {"every": 0}, ValueError, "every must be a positive"),
    (mpc.receding_horizon_ilqr, (TASK, W0, W1, 1.0), {}, ValueError, "alpha_of_s must be callable"),
    (mpc.receding_horizon_ilqr, (TASK, W0, W1, lambda s: np.nan), {}, ValueError, "non-finite weights"),
    (animation.belief_animation, ({"a": PATH}, {"a": np.full(11, 0.5)}, 0.1), {"frames": 1}, ValueError, "frames"),
    (animation.belief_animation, ({"a": PATH}, {"a": np.full(11, 1.5)}, 0.1), {}, ValueError, "probabilities"),
    (animation.belief_animation, ({"a": PATH}, {"b": np.full(11, 0.5)}, 0.1), {}, ValueError, "same names"),
    (explore.evident_view, (-1.0,), {}, ValueError, "alpha must be positive"),
    (explore.evident_view, (0.5, np.nan), {}, ValueError, "hazard_x must be a finite number"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i}-{c[0].__name__}-{c[4][:24]}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase.replace("(", r"\(").replace(")", r"\)")):
        fn(*args, **kwargs)
