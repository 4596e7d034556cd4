"""The simulated teaming task (chapter 5) on the chapter 4 value functions (quick grid): no false positives
for a perfect fit without noise, the detection probability and safety without a supervisor; bad inputs
(a table)."""

import numpy as np
import pytest

from mutual.study.teaming import Team, TeamingConfig, simulate_teaming, task_layout
from mutual.supervision.supervisor import NoisySupervisor

from helpers.study import Lib, case_id, member, resolve


@pytest.mark.parametrize("w", [0.5, 1.0])
def test_perfect_fit_without_noise_has_no_false_positives(functions, w):
    # Property of Sec. 4.5: robots avoiding at the supervisor's own safe set never draw a false
    # positive from a noiseless idealized supervisor. In discrete time on the quick grid the
    # controller needs a margin covering the grid value's error along the avoid arc (~0.4 here).
    library, conservative = functions
    own = member(library, w)
    sup = NoisySupervisor(own, 0.5, 0.0)
    standard = member(library, 1.0)
    teams = [Team(own, 0.5), Team(standard, 0.0)] * 4
    out = simulate_teaming(teams, [sup] * 8, [1, 2, 3, 4] * 2, TeamingConfig(duration=40, filter_margin=0.5), seed=2)
    learned, std = out.iloc[0::2], out.iloc[1::2]
    assert learned["false_positives"].sum() == 0
    assert learned["interventions"].sum() > 0          # undetected obstacles are still caught
    assert std["false_positives"].sum() > 0            # the Standard team alarms this supervisor


def test_detection_probability_and_safety_without_supervisor(functions):
    library, conservative = functions
    standard = member(library, 1.0)
    never = NoisySupervisor(standard, -50.0, 0.0)          # never intervenes
    # seeing every obstacle, robots never crash (a margin covers the quick grid's value error)
    cfg = TeamingConfig(duration=40, detection_prob=1.0, filter_margin=0.5)
    out = simulate_teaming([Team(standard, 0.0), Team(conservative, 0.0)] * 2, [never] * 4, [1, 2, 3, 4], cfg, seed=0)
    assert out["collisions"].sum() == 0 and out["interventions"].sum() == 0
    assert (out["trips"] > 0).all()
    out = simulate_teaming([Team(standard, 0.0)] * 6, [never] * 6, [1, 2, 3, 4, 5, 6],
                           TeamingConfig(duration=40), seed=0)
    rate = out["detected_encounters"].sum() / out["encounters"].sum()
    assert rate == pytest.approx(0.8, abs=0.05)
    assert out["collisions"].sum() > 0                      # blind robots crash without a supervisor
    assert np.allclose(out["score"], out["trips"] - out["collisions"] - 0.5 * out["interventions"])


def test_bad_arguments(functions):
    library, _ = functions
    with pytest.raises(ValueError, match="equally long"):
        simulate_teaming([Team(library[0])], [], [1])
    with pytest.raises(ValueError, match="detection_prob"):
        TeamingConfig(detection_prob=1.5)
    with pytest.raises(ValueError, match="alpha"):
        Team(library[0], float("nan"))


def test_record_repr_is_short(functions):
    library, _ = functions
    sup = NoisySupervisor(member(library, 1.0), 0.2, 0.05)
    _, record = simulate_teaming([Team(member(library, 1.0))], [sup], [1], TeamingConfig(duration=2.0), record=0)
    assert repr(record).startswith("TeamingRecord(") and len(repr(record)) < 120


CASES = [
    # --- the simulated study
    (Team, (Lib(1.0), float("nan")), {}, ValueError, "alpha must be a finite number"),
    (Team, ("not a value function",), {}, ValueError, "value must be a mutual.supervision.reachability.ValueFunction"),
    (TeamingConfig, (), {"detection_prob": 1.5}, ValueError, "detection_prob must lie in [0, 1]"),
    (TeamingConfig, (), {"n_robots": 0}, ValueError, "n_robots must be a positive integer"),
    (TeamingConfig, (), {"n_robots": 2.5}, ValueError, "n_robots must be a positive integer"),
    (TeamingConfig, (), {"removal_cost": float("nan")}, ValueError, "removal_cost must be a finite number"),
    (TeamingConfig, (), {"obstacle_gap": -1.0}, ValueError, "obstacle_gap must be a non-negative number"),
    (task_layout, (1.5, TeamingConfig()), {}, ValueError, "version must be a non-negative whole number"),
    (simulate_teaming, ([], [], []), {}, ValueError, "non-empty and equally long"),
    (simulate_teaming, ([Lib(team=1.0)], ["a supervisor"], [1]), {}, ValueError, "supervisors[0] must be a NoisySupervisor"),
    (simulate_teaming, ([Lib(team=1.0)], [Lib(supervisor=1.0)], [1.5]), {}, ValueError, "versions[0] must be a whole number"),
    (simulate_teaming, ([Lib(team=1.0)], [Lib(supervisor=1.0)], [1]), {"record": 3}, ValueError, "record must index a trial"),
]


@pytest.mark.parametrize("function, args, kwargs, exception, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_is_named(function, args, kwargs, exception, phrase, tmp_path, functions):
    args = [resolve(a, tmp_path, functions) for a in args]
    with pytest.raises(exception) as info:
        function(*args, **kwargs)
    assert phrase in str(info.value)
