"""Fixtures shared by the chapter 6-7 tests: the reference case of chapter 6 (a single integrator reaching G1
against G0) and the Dubins car's optima of Figure 7.1."""

import numpy as np
import pytest

from mutual.motion.evident import safety as es
from mutual.motion.legible import reaching_cost, single_integrator


DT, N = 0.01, 100
G0, G1 = np.array([-1.0, 1.0]), np.array([1.0, 1.0])


@pytest.fixture(scope="module")
def reference():
    return single_integrator(2, DT), reaching_cost(G1, DT), reaching_cost(G0, DT)


@pytest.fixture(scope="module")
def dubins():
    task, w0, w1 = es.figure_scenario("7.2")
    return task, w0, w1, es.solve_hypotheses(task, w0, w1)
