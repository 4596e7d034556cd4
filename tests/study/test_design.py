"""The within-subjects design of section 5.2.4, checked by brute-force counting; bad inputs (a table)."""

from itertools import permutations

import numpy as np
import pandas as pd
import pytest

from mutual.study.design import TREATMENTS, balanced_latin_square, comparison_label, design_balance, study_design

from helpers.study import case_id, resolve


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
def test_balanced_latin_square(n):
    sq = balanced_latin_square(n)
    assert sq.shape == ((n if n % 2 == 0 else 2 * n), n)
    for row in sq:
        assert sorted(row) == list(range(n))
    for col in sq.T:  # each condition equally often in each position
        assert len(set(np.bincount(col, minlength=n))) == 1
    follows = np.zeros((n, n), int)
    for row in sq:
        for a, b in zip(row[:-1], row[1:]):
            follows[a, b] += 1
    off = follows[~np.eye(n, dtype=bool)]
    assert len(set(off)) == 1  # each ordered pair of neighbours equally often


def test_twelve_participants_are_fully_balanced():
    d = study_design(12, seed=5)
    bal = design_balance(d)
    assert bal["all_pairs"] and bal["no_treatment_first_twice"] and bal["distinct_versions"]
    assert (bal["version_counts"].to_numpy() == 4).all()
    assert (bal["position_counts"].to_numpy() == 4).all()
    # every participant's six trials: each treatment twice, trials 1..6
    for _, g in d.groupby("participant"):
        assert sorted(g["trial"]) == list(range(1, 7))
        assert (g["treatment"].value_counts() == 2).all()
    # the twelve schedules (order of treatments over the six trials) are all different
    schedules = {tuple(g["treatment"]) for _, g in d.groupby("participant")}
    assert len(schedules) == 12
    # and each is a sequence of the three pairs, each oriented with distinct first treatments
    for sched in schedules:
        firsts = sched[0::2]
        assert sorted(firsts) == sorted(TREATMENTS)
        assert sorted(tuple(sorted(p)) for p in zip(sched[0::2], sched[1::2])) == sorted(
            tuple(sorted(p)) for p in permutations(TREATMENTS, 2) if p[0] < p[1])


def test_any_three_treatment_names():
    names = ("baseline", "our-method", "cautious")
    d = study_design(12, seed=1, treatments=names)
    bal = design_balance(d, treatments=names)
    assert set(d["treatment"]) == set(names) and bal["all_pairs"] and bal["no_treatment_first_twice"]
    assert (bal["version_counts"].to_numpy() == 4).all()
    # the same schedule as the thesis's names, relabelled
    ref = study_design(12, seed=1).replace(dict(zip(TREATMENTS, names)))
    assert (d["treatment"] == ref["treatment"]).all()


def test_bad_design_arguments():
    with pytest.raises(ValueError, match="n_participants"):
        study_design(0)
    with pytest.raises(ValueError, match="positive integer"):
        balanced_latin_square(0)


CASES = [
    # --- the design
    (study_design, (0,), {}, ValueError, "n_participants must be a positive integer"),
    (study_design, (12,), {"treatments": ("a", "a", "b")}, ValueError, "three different names"),
    (study_design, (12,), {"treatments": ("a", "b")}, ValueError, "treatments must be three names"),
    (comparison_label, ("Standard", "Reckless"), {}, ValueError, "treatment 'Reckless' is not one of"),
    (comparison_label, ("Learned", "Learned"), {}, ValueError, "two different treatments"),
    (balanced_latin_square, (True,), {}, ValueError, "n must be a positive integer"),
    (design_balance, (pd.DataFrame({"participant": [1]}),), {}, ValueError, "design is missing columns"),
]


@pytest.mark.parametrize("function, args, kwargs, exception, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_is_named(function, args, kwargs, exception, phrase, tmp_path, functions):
    args = [resolve(a, tmp_path, functions) for a in args]
    with pytest.raises(exception) as info:
        function(*args, **kwargs)
    assert phrase in str(info.value)
