"""Dragan and Srinivasa's legibility on the Dubins car."""

import numpy as np
import pytest

from mutual.motion.evident import safety as es


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
