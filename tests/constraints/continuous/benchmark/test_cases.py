"""The benchmark's cases (``benchmark.cases``): the split holds out one approached bound, one second truth and one
unconstrained case per system, and no case is in both splits."""

from mutual.constraints.continuous.benchmark import cases
from mutual.constraints.continuous.benchmark.setups import SETUPS


def test_split_holds_out_one_approached_bound_one_second_truth_and_one_unconstrained_case_per_system():
    held = cases("held-out")
    assert len(held) == 12 and len(cases("development")) == 24 and len(cases("all")) == 36
    for system in SETUPS:
        assert sorted(c.truth for c in held if c.system == system) == ["A", "B", "U"]
    assert not {c.id for c in held} & {c.id for c in cases("development")}
