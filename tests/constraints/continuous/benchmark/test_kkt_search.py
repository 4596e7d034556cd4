"""The KKT peer (Chou, Ozay and Berenson) on demonstrations that ARE locally optimal: a forward
solver (cvxpy for a double integrator before a wall; SLSQP for a point in the plane around a disk)
makes them, and the KKT conditions must give the constraint back -- and none without one."""

import numpy as np
import pytest
import scipy.optimize

from mutual.constraints.continuous import Grid, Problem, QuadraticReward, Recording, System
from mutual.constraints.continuous.benchmark import kkt_search
from mutual.constraints.continuous.benchmark.setups import SETUPS
from mutual.constraints.continuous.systemfile import SystemFile


def _recording(states, controls, dt):
    return Recording(tuple(f"d{k}" for k in range(len(states))), tuple(np.arange(len(s)) * dt for s in states),
                     tuple(states), tuple(np.vstack([u, np.full((1, u.shape[1]), np.nan)]) for u in controls), None, "opt")


def _double_integrator_optimal(spec, wall, starts):
    import cvxpy as cp
    p = spec.problem
    dt, L, rw = p.dt, p.horizon, p.reward
    A, B = np.array([[1, dt], [0, 1]]), np.array([dt ** 2 / 2, dt])       # RK4 is exact on this system
    states, controls = [], []
    for x0 in starts:
        X, U = cp.Variable((L + 1, 2)), cp.Variable(L)
        cost = sum((rw.state_weights @ cp.square(X[t] - rw.goal) + rw.control_weights[0] * cp.square(U[t])) * dt
                   for t in range(L)) + rw.terminal_weights @ cp.square(X[L] - rw.goal)
        cons = [X[0] == x0, cp.abs(U) <= 1] + [X[t + 1] == A @ X[t] + B * U[t] for t in range(L)]
        if wall is not None:
            cons.append(X[1:, 0] <= wall)
        cp.Problem(cp.Minimize(cost), cons).solve(solver=cp.CLARABEL)
        states.append(X.value)
        controls.append(U.value[:, None])
    return _recording(states, controls, dt)


@pytest.mark.parametrize("wall", [2.3, None])
def test_kkt_recovers_a_wall_from_optimal_double_integrator_demonstrations_and_nothing_without_one(wall):
    spec = SETUPS["double_integrator"].system_file()
    starts = np.random.default_rng(0).uniform([-0.5, -0.3], [0.5, 0.3], size=(6, 2))
    result = kkt_search.kkt_inference(spec, _double_integrator_optimal(spec, wall, starts))
    if wall is None:
        assert result.regions == []
    else:
        (bound,) = result.regions
        assert (bound.dim, bound.side) == (0, "upper") and bound.value == pytest.approx(wall, abs=1e-6)
        assert result.rounds[0]["rss1"] < 1e-6 * result.rounds[0]["rss0"]


def _plane_spec(tmp_path):
    (tmp_path / "plane_point.py").write_text(
        "import numpy as np\n\ndef single_integrator(x, u):\n    return np.asarray(u, dtype=float)\n")
    system = System("plane_point:single_integrator", ("x", "y"), ("m", "m"), ("vx", "vy"), ("m/s", "m/s"),
                    folder=str(tmp_path))
    grid = Grid.uniform([-3.0, -2.25], [3.0, 2.25], [24, 18], [False, False], ("x", "y"), ("m", "m"))
    controls = [[a, b] for a in (-5.0, 0.0, 5.0) for b in (-5.0, 0.0, 5.0)]
    reward = QuadraticReward([2.0, 0.0], [1.0, 1.0], [0.1, 0.1], [5.0, 5.0])
    problem = Problem(system, grid, controls, 0.1, 20, reward)
    return SystemFile(problem, {"families": ["disk"], "plane": (0, 1), "every": 2, "radii": None, "half_widths": None})


def _plane_optimal(problem, start, disk):
    """The optimal velocities of x_{t+1} = x_t + u_t dt (SLSQP with exact gradients), outside ``disk``."""
    rw, dt, L = problem.reward, problem.dt, problem.horizon
    q, c, Q, g = rw.state_weights, rw.control_weights, rw.terminal_weights, rw.goal
    lower = np.tril(np.ones((L + 1, L)), -1) * dt                       # X = start + lower @ U

    def states(u):
        return start + lower @ u.reshape(L, 2)

    def cost(u):
        U, X = u.reshape(L, 2), states(u)
        e = X - g
        value = ((e[:-1] ** 2) @ q + (U ** 2) @ c).sum() * dt + (e[-1] ** 2) @ Q
        grad = 2 * U * c * dt + lower[:-1].T @ (2 * e[:-1] * q * dt) + np.outer(lower[-1], 2 * e[-1] * Q)
        return value, grad.ravel()

    centre, radius = np.asarray(disk[:2]), disk[2]
    cons = {"type": "ineq", "fun": lambda u: ((states(u)[1:] - centre) ** 2).sum(axis=1) - radius ** 2,
            "jac": lambda u: np.einsum("tk,tj->tkj", lower[1:], 2 * (states(u)[1:] - centre)).reshape(L, 2 * L)}
    guess = np.tile([4.0 / (L * dt), 0.8 * np.sign(start[1] + 1e-9)], L)
    out = scipy.optimize.minimize(cost, guess, jac=True, method="SLSQP", constraints=[cons] if disk[2] else [],
                                  options={"ftol": 1e-14, "maxiter": 1000})
    assert out.success, out.message
    return states(out.x), out.x.reshape(L, 2)


@pytest.mark.parametrize("radius", [0.7, 0.0])
def test_kkt_recovers_a_disk_from_optimal_demonstrations_in_the_plane_and_nothing_without_one(tmp_path, radius):
    spec = _plane_spec(tmp_path)
    runs = [_plane_optimal(spec.problem, np.array([-2.0, y]), (0.1, -0.1, radius)) for y in (-0.4, 0.3, 0.5)]
    result = kkt_search.kkt_inference(spec, _recording([s for s, _ in runs], [u for _, u in runs], spec.problem.dt))
    if not radius:
        assert result.regions == []
        return
    (disk,) = result.regions
    assert np.hypot(disk.center[0] - 0.1, disk.center[1] + 0.1) < 0.03 and abs(disk.radius - radius) < 0.03
