"""SIMULATED cohorts for the power of a replication: a cohort follows the study, depends only on its
parameters (seeds follow the parameters, not the order), and smaller cohorts are its prefixes; bad inputs
(a table)."""

import numpy as np
import pytest

from mutual.study import cohort_power as cp, power_summary as ps

from helpers.study import TINY, assert_same_cohorts


def test_a_cohort_follows_the_study(inline):
    for c, table in enumerate(inline):
        kept = table[~table["excluded"]]
        assert len(kept) == 5 and (table["cohort"] == c).all()
        assert list(table["recruit"]) == list(range(len(table)))
        assert table.loc[table["excluded"], list(cp.FP_COLUMNS)].isna().all().all()
        fp = kept[list(cp.FP_COLUMNS)].to_numpy()
        assert np.all(fp >= 0) and np.allclose(fp * 2, np.round(fp * 2))  # the mean of two trials' counts
        assert set(table["kind"]) <= {k for k, _ in cp.MIXES["thesis"]}
    assert not all(a.equals(b) for a, b in zip(inline, inline[1:])), "cohorts must be independent draws"


def test_cohorts_depend_only_on_their_parameters(library, tasks, inline):
    again = [cp.simulate_cohort(t, *library) for t in reversed(tasks)][::-1]
    assert_same_cohorts(again, inline)
    other = cp.simulate_cohort(cp.CohortTask(cp.CohortSetting(n_scenes=10, trial_seconds=3.0, quick_grid=True,
                                                              noise_scale=2.0), 0, 5), *library)
    assert not other["sigma"].equals(inline[0]["sigma"])


def test_prefixes_are_the_smaller_cohorts(inline):
    y5, y3 = ps.analysed_outcomes(inline, 5), ps.analysed_outcomes(inline, 3)
    assert np.array_equal(y5[:, :3], y3)
    with pytest.raises(ValueError, match="fewer than 6"):
        ps.analysed_outcomes(inline, 6)


def test_seeds_follow_the_parameters_not_the_order():
    a, b = cp.CohortTask(TINY, 3, 5), cp.CohortTask(TINY, 3, 5)
    assert a.seed_sequence(0).generate_state(4).tolist() == b.seed_sequence(0).generate_state(4).tolist()
    assert cp.CohortTask(TINY, 4, 5).seed_sequence(0).generate_state(4).tolist() != a.seed_sequence(0).generate_state(4).tolist()
    assert cp.CohortSetting(mix="mostly-gradual").words() != cp.CohortSetting().words()


CASES = [
    (cp.CohortSetting, (), dict(mix="random"), "mix must be one of"),
    (cp.CohortSetting, (), dict(noise_scale=0.0), "noise_scale must be a positive number"),
    (cp.CohortSetting, (), dict(n_scenes=1), "n_scenes must be an integer >= 2"),
    (cp.CohortSetting, (), dict(trial_seconds=-1.0), "trial_seconds must be a positive number"),
    (cp.CohortTask, (cp.CohortSetting(), -1, 5), {}, "cohort must be an integer >= 0"),
    (cp.CohortTask, (cp.CohortSetting(), 0, 1), {}, "n_max must be an integer >= 2"),
    (cp.CohortTask, (cp.CohortSetting(), 0, 5, -3), {}, "seed must be an integer >= 0"),
    (cp.simulate_cohort, ("task", None, None), {}, "task must be a CohortTask"),
    (cp.simulate_cohort, (cp.CohortTask(cp.CohortSetting(), 0, 5), None, None), {}, "library must be a ValueLibrary"),
]


@pytest.mark.parametrize("fn, args, kwargs, phrase", CASES,
                         ids=[f"{getattr(c[0], '__name__', 'call')}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, phrase):
    with pytest.raises(ValueError) as err:
        fn(*args, **kwargs)
    assert phrase in str(err.value), f"{err.value!s} does not say {phrase!r}"
