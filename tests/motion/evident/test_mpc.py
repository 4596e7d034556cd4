"""Receding-horizon iLQR (legible MPC): a single plan is the open-loop legible optimum, frozen stages give the
remaining horizon's optimum, the schedule is followed, and a batch equals one at a time; bad inputs
(a table)."""

import numpy as np
import pytest

from mutual.motion.evident import mpc, safety as es
from mutual.motion.legible import linear_alpha_schedule


@pytest.fixture(scope="module")
def fig72():
    task, w0, w1 = es.figure_scenario("7.2", steps=30)
    return task, w0, w1, es.solve_hypotheses(task, w0, w1)


def test_a_single_plan_is_the_open_loop_legible_optimum(fig72):
    task, w0, w1, paths = fig72
    one = mpc.receding_horizon_ilqr(task, w0, w1, lambda s: 0.5, every=task.steps)
    np.testing.assert_allclose(one["xs"], paths["legible"].xs, atol=1e-9)


def test_frozen_stages_give_the_remaining_horizon_optimum(fig72):
    """The continuation cost from stage t equals a direct solve of the shorter task from the same state."""
    task, w0, w1, paths = fig72
    t = 12
    state = paths["H0"].xs[t]
    short = es.EvidentSafetyTask(x0=state, goal=task.goal, hazard=task.hazard, horizon=task.dt * (task.steps - t),
                                 steps=task.steps - t)
    direct = es.solve(short, w1).cost
    frozen = mpc.continuation_costs(task, w1, state[None], [t])[0]
    assert frozen == pytest.approx(direct, rel=1e-9, abs=1e-9)


def test_receding_horizon_follows_the_schedule(fig72):
    task, w0, w1, _ = fig72
    out = mpc.receding_horizon_ilqr(task, w0, w1, linear_alpha_schedule(0.25, 4.0), every=10)
    assert out["replans"] == 3
    np.testing.assert_allclose(out["alphas"][[0, 10, 20]], [0.25, 0.25 + 3.75 / 3, 0.25 + 7.5 / 3])
    np.testing.assert_allclose(es.rollout(task, out["us"]), out["xs"], atol=1e-12)


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


TASK, W0, W1 = es.figure_scenario("7.1", steps=10)


CASES = [
    (mpc.receding_horizon_ilqr, (TASK, W0, W1, lambda s: 1.0), {"every": 0}, ValueError, "every must be a positive"),
    (mpc.receding_horizon_ilqr, (TASK, W0, W1, 1.0), {}, ValueError, "alpha_of_s must be callable"),
    (mpc.receding_horizon_ilqr, (TASK, W0, W1, lambda s: np.nan), {}, ValueError, "non-finite weights"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i}-{c[0].__name__}-{c[4][:24]}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase.replace("(", r"\(").replace(")", r"\)")):
        fn(*args, **kwargs)
