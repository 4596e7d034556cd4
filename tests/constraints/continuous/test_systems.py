"""Continuous dynamics (``mutual.constraints.continuous.systems``): a bad dynamics spec is refused, and a
non-finite output names the system, the state and the control."""

import numpy as np
import pytest

from mutual.constraints.continuous import Grid, Problem, QuadraticReward, discretize, integrate
from mutual.constraints.continuous.systems import System

from helpers.continuous import write


def test_non_finite_dynamics_output_names_the_system_the_state_and_the_control(tmp_path, monkeypatch):
    write(tmp_path, "blowup.py", """
        import numpy as np
        def f(x, u, k=1.0):
            return np.stack([x[:, 1], np.where(x[:, 0] > 0.5, np.inf, -k * x[:, 0] + u[:, 0])], axis=1)
        """)
    system = System("blowup:f", ("q", "p"), ("m", "m/s"), ("u",), ("N",), folder=str(tmp_path))
    with pytest.raises(ValueError, match=r"system 'blowup:f': the dynamics gave a non-finite state .* x = \[0\.6"):
        integrate(system, np.array([[0.1, 0.0], [0.6, 0.0]]), np.array([0.0]), 0.1)
    grid = Grid.uniform([-1, -1], [1, 1], [5, 5], [False, False], ("q", "p"), ("m", "m/s"))
    problem = Problem(system, grid, [0.0], 0.1, 3, QuadraticReward([0, 0], [1, 1], [0], [0, 0]))
    with pytest.raises(ValueError, match="non-finite"):
        discretize(problem, scheduler="inline")


@pytest.mark.parametrize("spec, parameters, phrase", [
    ("nosuchmodule:f", {}, "cannot import module 'nosuchmodule'"),
    ("math:nosuch", {}, "module 'math' has no function 'nosuch'"),
    ("rocket", {}, "neither a named system"),
    ("pendulum", {"mass": "heavy"}, "'mass' must be a finite number"),
    ("pendulum", {"inertia": 1.0}, "takes no parameter 'inertia'"),
])
def test_a_bad_dynamics_spec_is_refused(spec, parameters, phrase):
    with pytest.raises(ValueError, match=phrase):
        System(spec, ("a", "b"), ("", ""), ("u",), ("",), parameters=parameters)
