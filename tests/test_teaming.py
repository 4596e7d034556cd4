"""The simulated teaming study (chapter 5) on the chapter 4 value functions (quick grid)."""

import numpy as np
import pytest

from mutual.supervision.reachability import unsafe_set_contains
from mutual.study.data import validate_trials
from mutual.study.design import TREATMENTS
from mutual.supervision.supervisor import NoisySupervisor
from mutual.supervision.fit import fit_supervisor
from mutual.study.cohort import (avoidance_onset, fraction_inside, phase2_interventions, predicted_and_observed,
                                 simulate_study, study_value_functions)
from mutual.study.misalignment import straight_approach_starts, supervised_approaches
from mutual.study.teaming import Team, TeamingConfig, _Stack, simulate_teaming
from mutual.supervision.dubins import unsafe_reach


@pytest.fixture(scope="module")
def functions():
    return study_value_functions(quick=True)


def _member(library, w):
    return library[library.index_of(w)]


@pytest.mark.parametrize("w", [0.5, 1.0])
def test_perfect_fit_without_noise_has_no_false_positives(functions, w):
    # Property of Sec. 4.5: robots avoiding at the supervisor's own safe set never draw a false
    # positive from a noiseless idealized supervisor. In discrete time on the quick grid the
    # controller needs a margin covering the grid value's error along the avoid arc (~0.4 here).
    library, conservative = functions
    own = _member(library, w)
    sup = NoisySupervisor(own, 0.5, 0.0)
    standard = _member(library, 1.0)
    teams = [Team(own, 0.5), Team(standard, 0.0)] * 4
    out = simulate_teaming(teams, [sup] * 8, [1, 2, 3, 4] * 2, TeamingConfig(duration=40, filter_margin=0.5), seed=2)
    learned, std = out.iloc[0::2], out.iloc[1::2]
    assert learned["false_positives"].sum() == 0
    assert learned["interventions"].sum() > 0          # undetected obstacles are still caught
    assert std["false_positives"].sum() > 0            # the Standard team alarms this supervisor


def test_half_of_noisy_interventions_lie_in_the_learned_set(functions):
    library, _ = functions
    rng = np.random.default_rng(4)
    sup = NoisySupervisor(_member(library, 0.5), 0.3, 0.05)
    table = phase2_interventions(sup, 400, rng)
    states = table[["x", "y", "theta"]].to_numpy()
    fit = fit_supervisor(library, states, values="grid")  # the supervisor judged on the grid: read the same values
    frac, _ = fraction_inside(fit.value_fn, states, fit.mu)
    assert frac == pytest.approx(0.5, abs=0.08)
    true_frac, _ = fraction_inside(sup.value_fn, states, sup.mu)
    assert true_frac == pytest.approx(0.5, abs=0.08)
    assert fit.w_max == 0.5


def test_detection_probability_and_safety_without_supervisor(functions):
    library, conservative = functions
    standard = _member(library, 1.0)
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


def test_exclusion_rule(functions):
    library, _ = functions
    standard = _member(library, 1.0)
    assert unsafe_set_contains(standard, standard, level=0.2)
    assert unsafe_set_contains(_member(library, 0.5), standard, level=0.2)
    assert not unsafe_set_contains(_member(library, 2.0), standard, level=0.0)


def test_study_tables_follow_the_schema(functions):
    library, conservative = functions
    kinds = ("standard-like", "conservative-like", "gradual", "agile")
    study = simulate_study(library, conservative, n_scenes=20, config=TeamingConfig(duration=20), seed=1, kinds=kinds)
    validate_trials(study.trials)
    assert study.simulated
    analysed = set(study.trials["participant"])
    assert analysed == set(study.participants.loc[~study.participants["excluded"], "participant"])
    assert "P04" not in analysed                            # the agile recruit is excluded
    table = predicted_and_observed(study)
    assert list(table["safe set"]) == list(TREATMENTS)
    assert table["predicted F.P. vs Std."].iloc[0] == 1.0


def test_bad_arguments(functions):
    library, _ = functions
    with pytest.raises(ValueError, match="equally long"):
        simulate_teaming([Team(library[0])], [], [1])
    with pytest.raises(ValueError, match="detection_prob"):
        TeamingConfig(detection_prob=1.5)
    with pytest.raises(ValueError, match="alpha"):
        Team(library[0], float("nan"))


def test_notebook_results(executed_notebook):
    res = executed_notebook("04_user_study")
    assert res["c5-latin-square-balanced"]["value"] is True
    assert res["c5-tukey-learned-standard-p"]["value"] == pytest.approx(0.0328, abs=0.002)  # from the thesis's numbers
    assert res["c5-learned-half-in-safe-set"]["simulated"]
    assert res["c5-learned-half-in-safe-set"]["value"] is True    # the share is consistent with 1/2
    assert "c5-detection-probability" not in res                      # an echo of a setting, not a claim
    assert all(entry["computed_by"].startswith("mutual.") and entry["note"] for entry in res.values())
    # one number, one row: a Table 5.1 ratio is checked from the table's own cells, the simulated one stands beside it
    predicted = res["c5-table51-predicted-learned"]
    assert predicted["value"] == pytest.approx(220 / 397) and not predicted["simulated"]
    assert predicted["beside"]["note"].startswith("SIMULATED") and 0 < predicted["beside"]["value"] < 1
    assert res["c5-trust-df-vs-analysed"]["value"] is True and res["c5-arcs-against-clusters"]["value"] is True


def test_stacked_interpolation_equals_each_value_function(functions):
    library, conservative = functions
    fns = [library[0], library[4], conservative]
    which = np.array([2, 0, 1, 0])
    rng = np.random.default_rng(3)
    states = np.concatenate([rng.uniform(-10, 10, (4, 5, 7, 2)), rng.uniform(-7, 7, (4, 5, 7, 1))], axis=-1)
    stack = _Stack(fns, which, "test")
    got = stack.interp(states)
    slope = stack.interp(states, fill_value=0.0, derivative=True)
    for b, g in enumerate(which):
        flat = states[b].reshape(-1, 3)
        assert np.allclose(got[b].ravel(), fns[g].interp(flat, fill_value=np.inf), equal_nan=False)
        assert np.allclose(slope[b].ravel(), fns[g].interp_dtheta(flat, fill_value=0.0))


def test_study_repr_is_short(functions):
    library, conservative = functions
    study = simulate_study(library, conservative, n_scenes=10, config=TeamingConfig(duration=5), seed=0,
                           kinds=("standard-like", "gradual"))
    text = repr(study)
    assert text.startswith("Study(SIMULATED 2 recruits") and len(text) < 400
    assert "Team(safe set V >= 0.5" in repr(Team(library[0], 0.5))


def test_onsets_match_the_closed_form_of_eq_5_1(functions):
    library, conservative = functions
    cell = library.grid_spec.spacings[0]
    assert avoidance_onset(_member(library, 1.0)) == pytest.approx(unsafe_reach(1.0, 1.0), abs=cell / 2)
    assert avoidance_onset(conservative) == pytest.approx(unsafe_reach(1.0, 2.0), abs=cell / 2)
    assert avoidance_onset(_member(library, 0.5)) == pytest.approx(unsafe_reach(0.5, 1.0), abs=cell / 2)


def test_following_the_supervisors_set_removes_false_alarms(functions):
    # Fig. 5.1: a supervisor with a gentler internal model alarms at every late (Standard) turn; robots that avoid
    # at alpha = mu + 2 sigma of the supervisor's own set draw (almost) no alarms, at alpha = mu about half
    library, _ = functions
    sup = NoisySupervisor(_member(library, 0.5), 0.3, 0.05)
    starts = straight_approach_starts(60, np.random.default_rng(0))
    share = {a: supervised_approaches(v, a, sup, starts, np.random.default_rng(1))["intervened"].mean()
             for v, a in [(_member(library, 1.0), 0.0), (sup.value_fn, 0.3), (sup.value_fn, 0.4)]}
    ignoring, at_mu, at_2sigma = share.values()
    assert ignoring == 1.0
    assert 0.25 < at_mu < 0.75
    assert at_2sigma <= 0.1


def test_record_repr_is_short(functions):
    library, _ = functions
    sup = NoisySupervisor(_member(library, 1.0), 0.2, 0.05)
    _, record = simulate_teaming([Team(_member(library, 1.0))], [sup], [1], TeamingConfig(duration=2.0), record=0)
    assert repr(record).startswith("TeamingRecord(") and len(repr(record)) < 120


@pytest.mark.parametrize("exact", [False, True], ids=["grid", "exact"])
def test_values_lie_above_a_level_beyond_its_reach(functions, exact):
    """_Stack.reach (which pairs the simulation evaluates): farther out than reach(level), no state's value is
    below the level, on the grid (any heading) and in closed form; and the bound is not vacuous: at level 0 it
    is the unsafe set's head-on reach sqrt(2 R r + r^2) to within a grid cell's diagonal."""
    library, conservative = functions if not exact else study_value_functions(quick=True, exact=True)
    fns = [library[0], _member(library, 1.0), library[len(library) - 1], conservative]
    which = np.repeat(np.arange(len(fns)), 50)
    stack = _Stack(fns, which, "test")
    rng = np.random.default_rng(7)
    level = rng.uniform(-1.0, 3.0, len(which))
    reach = stack.reach(level)
    w = stack.spec.half_width
    states = rng.uniform([-w, -w, -np.pi], [w, w, np.pi], (len(which), 400, 3))
    values = stack.interp(states)
    beyond = np.hypot(states[..., 0], states[..., 1]) > reach[:, None]
    assert beyond.mean() > 0.5 and np.all(values[beyond] >= level.repeat(400).reshape(beyond.shape)[beyond])
    at_zero = stack.reach(np.zeros(len(which)))[::50]
    expected = [unsafe_reach(f.w_max, f.obstacle_radius) for f in fns]
    assert np.all(at_zero >= np.array(expected) - 1e-9)
    assert np.all(at_zero <= np.array(expected) + (0 if exact else 2 * np.hypot(*stack.spec.spacings[:2])) + 1e-3)
