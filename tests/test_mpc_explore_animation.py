"""Receding-horizon iLQR, the Explore view and the belief animations (chapter 7)."""

import hashlib

import numpy as np
import pytest

from mutual.motion import animation
from mutual.motion.evident import explore, mpc
from mutual.motion.evident import safety as es
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


def test_explore_view_changes_with_its_inputs():
    def data(fig):
        return [line.get_xydata().copy() for ax in fig.axes for line in ax.get_lines()]
    base = data(explore.evident_view(0.5, -2.0, 2.0, steps=20))
    moved = data(explore.evident_view(0.5, 2.0, -2.0, steps=20))
    other_alpha = data(explore.evident_view(1.5, -2.0, 2.0, steps=20))
    assert len(base) >= 6
    assert not all(np.array_equal(a, b) for a, b in zip(base, moved))
    assert not all(np.array_equal(a, b) for a, b in zip(base, other_alpha))
    with pytest.raises(ValueError, match="alpha"):
        explore.evident_view(0.0)


def test_animation_is_deterministic_and_draws_every_path(tmp_path):
    task, w0, w1 = es.figure_scenario("7.1", steps=20)
    paths = es.solve_hypotheses(task, w0, w1)
    digests = []
    for i in range(2):
        anim = animation.task_belief_animation(task, w0, w1, paths, frames=5, title="test (simulated)")
        target = tmp_path / f"a{i}.gif"
        anim.save(target, writer="pillow", fps=5, dpi=40)
        digests.append(hashlib.sha256(target.read_bytes()).hexdigest())
    assert digests[0] == digests[1]
    ax, bx = anim._fig.axes
    assert len(bx.get_lines()) == 4  # three beliefs and the 1/2 line
    with pytest.raises(ValueError, match="frames"):
        animation.task_belief_animation(task, w0, w1, paths, frames=100)
