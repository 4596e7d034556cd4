"""Whole simulated cohorts of chapter 4's noisy supervisors: half of the noisy interventions lie in the learned
set, the exclusion rule, the study tables' schema, and the avoidance onsets against the closed form of
eq. 5.1; bad inputs (a table)."""

import numpy as np
import pytest

from mutual.study.cohort import (avoidance_onset, fraction_inside, learned_set_cluster, phase2_interventions,
                                 predicted_and_observed, simulate_study, simulated_recruits, write_simulated_study)
from mutual.study.data import validate_trials
from mutual.study.design import TREATMENTS
from mutual.study.teaming import Team, TeamingConfig
from mutual.supervision.dubins import unsafe_reach
from mutual.supervision.fit import fit_supervisor
from mutual.supervision.reachability import unsafe_set_contains
from mutual.supervision.supervisor import NoisySupervisor

from helpers.study import Lib, case_id, member, resolve


def test_half_of_noisy_interventions_lie_in_the_learned_set(functions):
    library, _ = functions
    rng = np.random.default_rng(4)
    sup = NoisySupervisor(member(library, 0.5), 0.3, 0.05)
    table = phase2_interventions(sup, 400, rng)
    states = table[["x", "y", "theta"]].to_numpy()
    fit = fit_supervisor(library, states, values="grid")  # the supervisor judged on the grid: read the same values
    frac, _ = fraction_inside(fit.value_fn, states, fit.mu)
    assert frac == pytest.approx(0.5, abs=0.08)
    true_frac, _ = fraction_inside(sup.value_fn, states, sup.mu)
    assert true_frac == pytest.approx(0.5, abs=0.08)
    assert fit.w_max == 0.5


def test_exclusion_rule(functions):
    library, _ = functions
    standard = member(library, 1.0)
    assert unsafe_set_contains(standard, standard, level=0.2)
    assert unsafe_set_contains(member(library, 0.5), standard, level=0.2)
    assert not unsafe_set_contains(member(library, 2.0), standard, level=0.0)


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
    assert avoidance_onset(member(library, 1.0)) == pytest.approx(unsafe_reach(1.0, 1.0), abs=cell / 2)
    assert avoidance_onset(conservative) == pytest.approx(unsafe_reach(1.0, 2.0), abs=cell / 2)
    assert avoidance_onset(member(library, 0.5)) == pytest.approx(unsafe_reach(0.5, 1.0), abs=cell / 2)


CASES = [
    (simulate_study, (Lib(), Lib(conservative=True)), {"kinds": ("standard-like", "bogus")}, ValueError,
     "unknown participant kind(s) ['bogus']"),
    (simulate_study, (Lib(), Lib(conservative=True)), {"kinds": "gradual"}, ValueError, "kinds must be a non-empty list"),
    (simulate_study, (Lib(), Lib(conservative=True)), {"n_scenes": 1}, ValueError, "n_scenes must be an integer >= 2"),
    (simulate_study, (Lib(), Lib(conservative=True)), {"kinds": ("agile", "agile"), "n_scenes": 10}, ValueError,
     "all 2 simulated recruits were excluded"),
    (simulate_study, (Lib(1.0), Lib(conservative=True)), {}, ValueError, "library must be a"),
    (simulated_recruits, (Lib(),), {"sigma_range": (0.1, 0.05)}, ValueError, "sigma_range must satisfy 0 <= low <= high"),
    (learned_set_cluster, (float("nan"), 0.3), {}, ValueError, "w_max must be a finite number"),
    (fraction_inside, (Lib(1.0), [[np.nan, 0.0, 0.0]]), {}, ValueError, "states contains NaN"),
    (fraction_inside, (Lib(1.0), [[1.0, 0.0, 0.0]]), {"level": float("inf")}, ValueError, "level must be a finite number"),
    (avoidance_onset, (Lib(1.0),), {"level": -5.0}, ValueError, "never meets {V < -5}"),
    (write_simulated_study, ("not a study", "/tmp"), {}, ValueError, "must be a simulated Study"),
]


@pytest.mark.parametrize("function, args, kwargs, exception, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_is_named(function, args, kwargs, exception, phrase, tmp_path, functions):
    args = [resolve(a, tmp_path, functions) for a in args]
    with pytest.raises(exception) as info:
        function(*args, **kwargs)
    assert phrase in str(info.value)
