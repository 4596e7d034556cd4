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


# A planar system with a two-dimensional control, and user modules that go wrong in the usual ways

PLANAR = textwrap.dedent("""\
    system = "{spec}"
    [state]
    names = ["x", "y"]
    units = ["m", "m"]
    low = [0.0, 0.0]
    high = [3.0, 2.0]
    cells = [9, 6]
    [control]
    names = ["vx", "vy"]
    units = ["m/s", "m/s"]
    values = {values}
    [time]
    dt = 0.25
    horizon = 12
    [reward]
    goal = [2.75, 1.0]
    state_weights = [1.0, 1.0]
    [simulate]
    hidden = ["y <= 1.4"]
    start = {start}
    n = 6
    fine_cells = [18, 12]
    """)
CONTROLS_2D = "[[1.0, 0.0], [0.0, 1.0], [0.0, -1.0], [-1.0, 0.0], [0.0, 0.0]]"
MODULES = {
    "planar": "import numpy as np\ndef f(x, u, speed=1.0):\n    return speed * np.asarray(u, dtype=float)\n",
    "one_state": "import numpy as np\ndef f(x, u):\n    px, py = x\n    return np.array([u[0], u[1]])\n",
    "one_row": "import numpy as np\ndef f(x, u):\n    return np.array([u[0], u[1]])\n",
    "exits": "import sys\nsys.exit(0)\n",
    "raises": "raise RuntimeError('licence server unreachable')\n",
    "fails_later": "import numpy as np\ndef f(x, u):\n    if (x[:, 0] > 2.9).any():\n        raise ArithmeticError("
                   "'left the table')\n    return np.asarray(u, float)\n",
}


def planar_system(tmp_path, spec="planar:f", values=CONTROLS_2D, start="[0.25, 1.0]"):
    """A planar system file (x' = u, a 2-D control set, a hidden wall y <= 1.4) in ``tmp_path`` with ``spec``'s
    dynamics module beside it (``MODULES``: the good one and the usual mistakes in user code)."""
    for name, source in MODULES.items():
        (tmp_path / f"{name}.py").write_text(source)
    path = tmp_path / f"{spec.split(':')[0]}.toml"
    path.write_text(PLANAR.format(spec=spec, values=values, start=start))
    return path


def benchmark_case(case_id):
    """The benchmark case named ``case_id``."""
    from mutual.constraints.continuous.benchmark import all_cases
    return next(c for c in all_cases() if c.id == case_id)
