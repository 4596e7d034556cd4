"""Figure 6.3's path measures (heading turn, chord deviation, outward excursion, juke) on paths whose values
are known by construction; bad inputs (a table)."""

import numpy as np
import pytest

from mutual.motion.legible import path_measures


DT, N = 0.01, 100


def test_path_measures_of_figure_6_3():
    from mutual.motion.legible import path_measures as pm
    goal = np.array([-2.0, 4.0])
    straight = np.linspace([0.0, 0.0], goal, 101)
    assert pm.heading_turn(straight) == pytest.approx(0.0, abs=1e-6)
    assert pm.chord_deviation(straight, 0) == pytest.approx(0.0, abs=1e-12)
    assert pm.outward_excursion(straight, goal, -1) == pytest.approx(0.0, abs=1e-12)
    assert not pm.juke(straight, goal)["juke"]
    # sideways to the goal's x first, then straight up: a 90-degree juke that reaches the goal
    sideways = np.linspace([0.0, 0.0], [-2.0, 0.0], 11)
    up = np.linspace([-2.0, 0.0], goal, 91)[1:]
    jk = pm.juke(np.vstack([sideways, up]), goal)
    assert jk["juke"] and jk["turn"] == pytest.approx(90.0, abs=1e-6) and jk["gap"] == pytest.approx(0.0)
    # a path that bulges to the left of the start-goal segment strays outwards (towards smaller x)
    bulge = straight + np.c_[-np.sin(np.linspace(0, np.pi, 101)), np.zeros(101)]
    assert pm.outward_excursion(bulge, goal, -1) > 0.1 > pm.outward_excursion(bulge, goal, +1)


SMALL_DT, SMALL_N = 0.1, 10
XS = np.linspace([0.0, 0.0], [1.0, 1.0], SMALL_N + 1)
NAN_XS = XS.copy()
NAN_XS[4, 0] = np.nan


CASES = [
    (path_measures.time_to_reach, (NAN_XS, 0.5, SMALL_DT), {}, ValueError, "xs must be a finite"),
]


@pytest.mark.parametrize("fn,args,kwargs,error,phrase", CASES,
                         ids=[f"{i}-{c[0].__name__ if hasattr(c[0], '__name__') else c[0]}" for i, c in
                              enumerate(CASES)])
def test_bad_input_is_refused_with_a_clear_message(fn, args, kwargs, error, phrase):
    if error is None:
        out = fn(*args, **kwargs)
        assert np.all(np.isfinite(out.us))
        return
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value)
