"""Small continuous problems shared by the continuous-constraint tests: the double integrator and the pendulum
on coarse grids, recordings of given controls, and files written for a loader."""

import textwrap

import numpy as np

from mutual.constraints.continuous import Grid, Problem, QuadraticReward, Recording, named_system


DI = named_system("double_integrator")


def recording_of(problem, starts, controls):
    """Demonstrations integrated exactly by the problem's own step, controls recorded."""
    states, ctrl = [], []
    for x0, us in zip(starts, controls):
        xs = [np.asarray(x0, dtype=float)]
        for u in us:
            xs.append(problem.step(xs[-1][None], np.array([[u]]))[0])
        states.append(np.array(xs))
        ctrl.append(np.r_[np.asarray(us, dtype=float), np.nan][:, None])
    times = tuple(np.arange(len(s)) * problem.dt for s in states)
    return Recording(tuple(f"d{n}" for n in range(len(states))), times, tuple(states), tuple(ctrl))


def pendulum(cells=9, scheme="sample"):
    system = named_system("pendulum")
    grid = Grid.uniform([-np.pi, -6.0], [np.pi, 6.0], [cells, cells], [True, False], system.state_names,
                        system.state_units)
    reward = QuadraticReward([np.pi, 0.0], [1.0, 0.05], [0.02], [5.0, 0.5])
    return Problem(system, grid, [-2.0, 0.0, 2.0], 0.1, 8, reward, scheme=scheme, samples=8)


def pendulum_problem(cells=(9, 9)):
    system = named_system("pendulum")
    grid = Grid.uniform([-np.pi, -8.0], [np.pi, 8.0], cells, [True, False], system.state_names, system.state_units)
    return Problem(system, grid, [-3.0, 0.0, 3.0], 0.1, 10, QuadraticReward([np.pi, 0], [1, 0.1], [0.0], [1, 1]))


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path
