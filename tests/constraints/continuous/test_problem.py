"""The continuous problem (``problem``): a bad grid, control set or task is refused naming the argument."""

import pytest

from helpers.continuous import pendulum_problem


@pytest.mark.parametrize("change, phrase", [
    (dict(dt=-0.1), "dt: must be a positive number"),
    (dict(horizon=0), "horizon: must be an integer >= 1"),
    (dict(scheme="grid"), "scheme: must be one of"),
    (dict(samples=0), "samples: must be an integer >= 1"),
    (dict(controls=[[1.0, 2.0]]), "controls: need a list of controls with 1 value"),
])
def test_a_bad_problem_is_refused(change, phrase):
    with pytest.raises(ValueError, match=phrase):
        pendulum_problem().replace(**change)
