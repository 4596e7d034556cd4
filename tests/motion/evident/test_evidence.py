"""How evident a path's avoidance is: the distance to a point in closed form, the evidence rules, and the
Dubins story (H1 slightly farther, the legible path obviously farther); bad inputs (a table)."""

import numpy as np
import pytest

from mutual.motion.evident import evidence


def test_dubins_story_h1_slightly_farther_legible_obviously_farther(dubins):
    task, _, _, results = dubins
    d = {k: evidence.distance_to_point(r.xs, task.hazard, task.dt) for k, r in results.items()}
    assert d["H0"]["integral"] < d["H1"]["integral"] < 1.05 * d["H0"]["integral"]
    assert d["legible"]["integral"] > 1.3 * d["H1"]["integral"]
    assert d["legible"]["min"] > 1.5 * d["H1"]["min"]


def test_distance_to_point_closed_form():
    t = np.linspace(0, 2, 201)
    xs = np.c_[t - 1, np.ones_like(t)]  # the line y = 1 from x = -1 to 1, unit speed
    d = evidence.distance_to_point(xs, [0, 0], dt=0.01)
    assert d["min"] == pytest.approx(1.0)
    assert d["integral"] == pytest.approx(np.arcsinh(1) + np.sqrt(2), rel=1e-5)  # int sqrt(1 + s^2) ds


def test_evidence_rules():
    t = np.linspace(0, 1, 11)
    h0 = np.c_[2 * t - 1, np.full_like(t, 0.2)]  # passes 0.2 from the hazard at the origin at t = 0.5
    far = np.c_[2 * t - 1, 0.2 + np.minimum(t, 1 - t) * 2]  # bends away from the start
    lead = evidence.lead_time(far, h0, [0.0, 0.0], 0.1)
    assert lead["t_close"] == pytest.approx(0.5)
    assert lead["t_separate"] == pytest.approx(0.1)
    assert evidence.lead_time(h0, h0, [0.0, 0.0], 0.1)["lead"] == -np.inf
    assert evidence.close_but_clear(0.5, 0.3) and not evidence.close_but_clear(0.7, 0.3)
    holds, gain, ratio = evidence.obvious_avoidance(far, h0, h0 + [0, 0.01], [0.0, 1.0], 0.1)
    assert not holds and gain < 0  # 'far' bends towards this hazard, so it is not more evident
    holds, gain, ratio = evidence.obvious_avoidance(far, h0, h0 + [0, 0.01], [0.0, -0.5], 0.1)
    assert ratio > 1 and holds == (gain >= 0.25 and ratio >= 1.5)


PATH = np.c_[np.linspace(0, 1, 11), np.zeros(11)]


CASES = [
    # evidence measures
    (evidence.distance_to_point, (np.zeros(3), [0, 0], 0.1), {}, ValueError, "xs must have shape"),
    (evidence.distance_to_point, (PATH, [0, 0, 0], 0.1), {}, ValueError, "point must be a finite planar point"),
    (evidence.distance_to_point, (PATH, [0, 0], 0.0), {}, ValueError, "dt must be a positive"),
    (evidence.lead_time, (PATH, PATH[:5], [0, 0], 0.1), {}, ValueError, "same number of knots"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i}-{c[0].__name__}-{c[4][:24]}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase.replace("(", r"\(").replace(")", r"\)")):
        fn(*args, **kwargs)
