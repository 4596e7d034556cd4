"""The continuous loop's supervisor: the closed-form library samples the closed form, and the exact
false-positive probability agrees with sampled judgements; bad inputs (a table)."""

import numpy as np
import pytest

from mutual.cycle.supervision import (closed_form_library, closed_form_value_function, collect_interventions,
                                      false_positive_study)
from mutual.supervision.dubins import avoid_value_closed_form
from mutual.supervision.reachability import QUICK_GRID
from mutual.supervision.supervisor import NoisySupervisor


def test_closed_form_library_samples_the_closed_form():
    lib = closed_form_library([0.5, 1.0], 1.0, QUICK_GRID)
    xs, ys, ts = QUICK_GRID.coordinate_vectors
    nodes = np.stack(np.meshgrid(xs, ys, ts, indexing="ij"), -1).reshape(-1, 3)
    np.testing.assert_allclose(lib[1].values.ravel(), avoid_value_closed_form(nodes, 1.0, 1.0), atol=1e-5)
    assert lib.w_maxes.tolist() == [0.5, 1.0]


def test_exact_false_positive_probability_agrees_with_sampled_judgements():
    sup_vf = closed_form_value_function(0.75, 1.0, QUICK_GRID)
    supervisor = NoisySupervisor(sup_vf, 0.5, 0.3)
    controller = closed_form_value_function(1.0, 1.0, QUICK_GRID)
    n = 300
    out = false_positive_study(supervisor, {"standard": (controller, 0.3)}, n, np.random.default_rng(0), 7.5, dt=0.05)
    row = out.iloc[0]
    assert 0.0 < row["p_false_positive"] < 1.0
    assert abs(row["sampled"] - row["p_false_positive"]) < 5 * np.sqrt(0.25 / n)
    assert row["low"] <= row["p_false_positive"] <= row["high"]
    # a noiseless supervisor and robots that stay well clear of its level: no false positives at all
    calm = NoisySupervisor(sup_vf, 0.2, 0.0)
    out = false_positive_study(calm, {"wide": (controller, 1.5)}, 40, np.random.default_rng(1), 7.5, dt=0.05)
    assert out["p_false_positive"].iloc[0] == 0.0 and out["closest_edge"].iloc[0] > 0.2


CASES = [
    (closed_form_library, ([1.0, 1.0], 1.0), {}, ValueError, "w_maxes"),
    (closed_form_library, ([-1.0], 1.0), {}, ValueError, "w_maxes"),
    (closed_form_value_function, (1.0, 1.0, "grid"), {}, ValueError, "grid_spec"),
    (collect_interventions, (None, 0, None, 7.5), {}, ValueError, "n: must be a positive integer"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{c[0].__name__ if hasattr(c[0], '__name__') else 'call'}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase):
        fn(*args, **kwargs)
