"""Counted work of Algorithms 1 and 3 (one pass over S per candidate and step) and the fitted power law,
against a known power and the operation counts by hand."""

import numpy as np
import pytest

from mutual.constraints.backup import log_partition, value_ratio
from mutual.constraints.complexity import gridworld_ranking_work, power_law_exponent
from mutual.constraints.gridworld import gridworld


def test_power_law_exponent_recovers_a_known_power():
    from mutual.constraints.complexity import all_single_candidates, best_time, power_law_exponent
    sizes = np.array([10.0, 20.0, 40.0, 80.0])
    assert power_law_exponent(sizes, 3e-4 * sizes ** 2.5) == pytest.approx(2.5)
    with pytest.raises(ValueError, match="sizes/cost"):
        power_law_exponent([1.0], [1.0])
    with pytest.raises(ValueError, match="repeats"):
        best_time(lambda: None, 0)
    g = gridworld(3, 3, (0, 0), (2, 0))
    masks = all_single_candidates(g.mdp)
    assert masks.shape == (9, 9, 18) and not masks[:, 4, 13].any() and masks[:, 3, 13].all()


@pytest.mark.parametrize("sparse", [False, True])
def test_counted_work_is_one_pass_over_S_per_candidate_and_step(sparse):
    from mutual.constraints.complexity import all_single_candidates, counting_multiply_adds, gridworld_ranking_work
    g = gridworld(4, 4, (0, 0), (3, 0), slip=0.1, horizon=5, sparse=sparse)
    masks = all_single_candidates(g.mdp)
    S, T, K = g.mdp.dense_transitions(), g.mdp.horizon, masks.shape[2]
    touched = np.count_nonzero(S) if sparse else S.size   # the x' loop of Algorithm 4, per (t, x, a, candidate)
    with counting_multiply_adds() as tally:
        log_partition(g.mdp, masks, engine="numpy")
    assert tally == {"products": T, "multiply_adds": T * touched * K}
    with counting_multiply_adds() as tally:
        value_ratio(g.mdp, np.ones(masks.shape[:2], dtype=bool), masks)
    assert tally["multiply_adds"] == T * touched * (K + 1)  # plus the baseline backup of C0
    assert gridworld_ranking_work(4, sparse=sparse, horizon=5) == T * touched * K
    with pytest.raises(ValueError, match="algorithm"):
        gridworld_ranking_work(4, algorithm=5)


def test_algorithm_3_and_1_counted_work():
    T, A, n = 20, 9, 6
    X = n * n
    assert gridworld_ranking_work(n, algorithm=3) == T * X ** 2 * A * (X + A + 1)
    assert gridworld_ranking_work(n, algorithm=1) == 2 * T * X ** 2 * A  # one backup, one forward pass


CASES = [
    (power_law_exponent, ([1.0], [1.0]), {}, ValueError, "sizes/cost"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i:02d}-{case[0].__name__}" for i, case in enumerate(CASES)])
def test_bad_input_raises_a_clear_error(fn, args, kwargs, error, phrase):
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value), f"message {str(info.value)!r} should mention {phrase!r}"
