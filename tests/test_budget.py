"""The estimator of a request's memory and time (``mutual.budget``): its memory estimates against the peak that
tracemalloc measures on small instances of each kind of request, its refusals (memory beyond what is
available, time beyond a stated limit, the flag or keyword that goes ahead), and the library's entry
points refusing a huge request before they allocate anything."""

import math
import os
import time
import tracemalloc

import numpy as np
import pandas as pd
import pytest

from mutual import budget

EXAMPLES = os.path.join(os.path.dirname(__file__), os.pardir, "data", "examples")


def _peak(fn):
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def _pendulum(cells, scheme):
    from mutual.constraints.continuous import load_system
    from mutual.constraints.continuous.experiments import with_cells
    return with_cells(load_system(os.path.join(EXAMPLES, "pendulum.toml")).problem, cells).replace(scheme=scheme)


def _spec(distractors, steps):
    from mutual.motion.spec import legible_spec
    d = [[10 * math.cos(2 * math.pi * i / distractors), 20 + 10 * math.sin(2 * math.pi * i / distractors)]
         for i in range(distractors)]
    return legible_spec({"dynamics": "single-integrator", "start": [0.0, 0.0], "goal": [4.0, 4.0],
                         "distractors": d, "horizon": 1.0, "steps": steps, "alpha": 1.0})


def _anova(levels, subjects=3):
    from mutual.study import rm_anova
    rng = np.random.default_rng(0)
    data = pd.DataFrame([(f"s{s}", f"L{k:04d}", rng.normal()) for s in range(subjects) for k in range(levels)],
                        columns=["s", "level", "v"])
    return rm_anova(data, "v", "level", "s")


def _measured_and_estimated(kind):
    if kind in ("sample", "barycentric"):
        from mutual.constraints.continuous.discretization import discretize
        p = _pendulum((81, 81), kind)
        return (_peak(lambda: discretize(p, scheduler="inline")),
                budget.discretization((81, 81), p.n_actions, p.samples, kind, p.substeps))
    if kind == "demonstrations":
        from mutual.constraints import sample_demonstrations, world
        mdp = world.load_world(os.path.join(EXAMPLES, "world.toml")).mdp
        return _peak(lambda: sample_demonstrations(mdp, 10_000, rng=0)), budget.demonstrations(10_000, mdp.horizon)
    from mutual.motion.spec import solve_legible
    spec = _spec(40, 300)
    return _peak(lambda: solve_legible(spec)), budget.legible(300, 41)


@pytest.mark.parametrize("kind", ["sample", "barycentric", "demonstrations", "legible"])
def test_memory_estimates_are_within_a_small_factor_of_the_measured_peak(kind):
    measured, estimate = _measured_and_estimated(kind)
    assert 0.4 <= estimate.bytes / measured <= 3, (kind, measured, estimate.bytes)


def test_an_array_is_estimated_exactly():
    assert budget.array((3, 1000, 7), 8).bytes == np.empty((3, 1000, 7)).nbytes
    assert budget.array((10 ** 9 + 1,), 8).bytes == 8 * (10 ** 9 + 1)       # the 7.45 GiB of --cells 10**9


@pytest.mark.parametrize("n_bytes, shown", [(7.45 * 2 ** 30, "7.45 GiB"), (24.5 * 2 ** 40, "2.51e+04 GiB"),
                                            (3 * 2 ** 20, "3 MiB"), (2 ** 90, "1.15e+18 GiB")])
def test_memory_is_shown_in_gib(n_bytes, shown):
    assert budget.memory(n_bytes) == shown


@pytest.mark.parametrize("seconds, shown", [(12, "12 s"), (90, "1.5 minutes"), (3000, "50 minutes"),
                                            (7200, "2 hours"), (86400 * 3, "3 days"), (3.15e7 * 2, "2 years")])
def test_durations_are_shown_in_their_unit(seconds, shown):
    assert budget.duration(seconds) == shown


def test_available_memory_is_positive_and_at_most_the_physical_memory():
    physical = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    assert 0 < budget.available_bytes() <= physical


BIG = budget.Estimate("a big request", 10 * 2 ** 30, 3600.0, "ask for less")


@pytest.mark.parametrize("free, minutes, allow, refused, phrases", [
    (2 ** 30, None, None, True, ["10 GiB", "1 GiB are available", "ask for less", "allow_large=True"]),
    (2 ** 40, None, None, False, []),                                   # the library: no time limit
    (2 ** 40, 30, None, True, ["1 hours", "the limit is 30 minutes", "allow_large=True"]),
    (2 ** 40, 61, None, False, []),
    (2 ** 30, 30, True, False, []),                                      # allowed: whatever the estimate
])
def test_check_refuses_beyond_memory_or_the_stated_time(monkeypatch, free, minutes, allow, refused, phrases):
    monkeypatch.setattr(budget, "available_bytes", lambda: free)
    if not refused:
        assert budget.check(BIG, allow_large=allow, minutes=minutes) is BIG
        return
    with pytest.raises(budget.TooLarge) as err:
        budget.check(BIG, allow_large=allow, minutes=minutes)
    assert isinstance(err.value, ValueError) and err.value.estimate is BIG
    for phrase in phrases:
        assert phrase in str(err.value)


def test_the_limits_in_force_apply_inside_their_block_only(monkeypatch):
    monkeypatch.setattr(budget, "available_bytes", lambda: 2 ** 40)
    with budget.limits(minutes=30, flag="--allow-large"):
        with pytest.raises(budget.TooLarge, match="pass --allow-large to go ahead"):
            budget.check(BIG)
        assert budget.check(BIG, allow_large=True) is BIG
    with budget.limits(minutes=30, allow_large=True):
        assert budget.check(BIG) is BIG
    assert budget.check(BIG) is BIG                                     # outside: no time limit


def test_a_request_let_through_is_said_when_it_is_long_or_large(monkeypatch):
    """Inside limits(say=...): a request above NOTICE_SECONDS or NOTICE_BYTES is said, before it starts, whether
    the limits or allow_large let it through, unless one said before needs as much time and memory (its part, or
    a repeat); a small one is not; a refused one raises without a word."""
    monkeypatch.setattr(budget, "available_bytes", lambda: 2 ** 40)
    small = budget.Estimate("a small request", 2 ** 20, 1.0, "ask for less")
    large = budget.Estimate("a large request", 4 * 2 ** 30, 1.0, "ask for less")
    part = budget.Estimate("a part of it", 2 ** 30, 600.0, "ask for less")
    said = []
    with budget.limits(minutes=120, say=said.append):
        budget.check(small)
        budget.check(BIG)
        budget.check(large)
        budget.check(part)
        budget.check(BIG)
    assert said == ["a big request: about 10 GiB of memory and 1 hours (estimated before starting; 1.02e+03 GiB are "
                    "available, the limit is 120 minutes)"]
    with budget.limits(minutes=120, say=said.append):
        budget.check(large)
    assert said[-1] == ("a large request: about 4 GiB of memory and 1 s (estimated before starting; 1.02e+03 GiB "
                        "are available, the limit is 120 minutes)")
    with budget.limits(minutes=30, say=said.append):
        with pytest.raises(budget.TooLarge):
            budget.check(BIG)
        assert len(said) == 2
        budget.check(BIG, allow_large=True)
    assert len(said) == 3 and "the limit is 30 minutes" in said[-1]
    budget.check(BIG)                                                     # outside the block: nobody to tell
    assert len(said) == 3


@pytest.mark.parametrize("text, minutes", [("", 30), ("5", 5.0), (" 0.5 ", 0.5)])
def test_the_command_lines_time_limit_comes_from_the_environment(text, minutes):
    assert budget.command_line_minutes({budget.MINUTES_ENV: text}) == minutes


@pytest.mark.parametrize("text", ["0", "-3", "soon", "nan", "inf", "1e400", "-inf"])
def test_a_bad_time_limit_is_named(text):
    with pytest.raises(ValueError, match=f"MUTUAL_MAX_MINUTES = '{text}'"):
        budget.command_line_minutes({budget.MINUTES_ENV: text})


def test_the_quick_grid_is_offered_only_to_a_larger_grid():
    from mutual.supervision import FULL_GRID, QUICK_GRID
    assert budget.QUICK_GRID_NODES == math.prod(QUICK_GRID.shape)
    assert "--grid quick" in budget.value_library(100, FULL_GRID.shape).knob
    assert "--grid quick" not in budget.value_library(100, QUICK_GRID.shape).knob


def test_an_mppi_request_names_its_samples_and_plan_steps():
    plain, mppi = budget.rollouts(2, 40, 4, 3), budget.rollouts(2, 40, 4, 3, plans=10 ** 9, plan_steps=20)
    assert "[simulate] samples" in mppi.knob and "[simulate] plan_steps" in mppi.knob and "MPPI" in mppi.what
    assert "[simulate] samples" not in plain.knob


def _refused_quickly(call):
    start = time.perf_counter()
    with pytest.raises(budget.TooLarge) as err:
        call()
    assert time.perf_counter() - start < 5        # refused from the sizes, nothing computed first
    return str(err.value)


def test_library_entry_points_refuse_before_they_allocate():
    from mutual.constraints import sample_demonstrations, world
    from mutual.constraints.continuous.discretization import discretize
    from mutual.motion.spec import solve_legible
    from mutual.study import pairwise_comparisons
    from mutual.supervision.reachability import GridSpec, value_library
    mdp = world.load_world(os.path.join(EXAMPLES, "world.toml")).mdp
    assert "GiB" in _refused_quickly(lambda: sample_demonstrations(mdp, 10 ** 12, rng=0))
    assert "samples" in _refused_quickly(lambda: discretize(_pendulum((41, 41), "sample").replace(samples=10 ** 9)))
    with budget.limits(minutes=30):
        assert "3,001 goals" in _refused_quickly(lambda: solve_legible(_spec(3000, 10_000)))
        assert "value functions" in _refused_quickly(
            lambda: value_library(np.linspace(0.5, 3, 5000), 1.0, GridSpec(8.0, (101, 101, 64)), cache=False))
        anova = _anova(1000)
        assert "499,500 pairs" in _refused_quickly(lambda: pairwise_comparisons(anova))
        assert pairwise_comparisons(_anova(4), allow_large=True).shape[0] == 6


@pytest.mark.parametrize("estimate, seconds", [
    (budget.anova(1000, 3), 499_500 * budget.ANOVA_PAIR_SECONDS + 3000 * budget.ANOVA_ROW_SECONDS),
    (budget.anova(2, 200_000, 400_000), 1 * budget.ANOVA_PAIR_SECONDS + 400_000 * budget.ANOVA_ROW_SECONDS),
    (budget.csv_table("d.csv", 10 ** 6, 200_000), 10 ** 6 * budget.CSV_BYTE_SECONDS + 200_000 * budget.CSV_COLUMN_SECONDS),
    (budget.legible(10_000, 3001), 10_000 * 3001 * budget.LQ_STEP_SECONDS),
    (budget.discretization((41, 41), 5, 16), 41 * 41 * 5 * 16 * 4 * budget.RK4_SECONDS),
])
def test_times_are_the_work_times_its_measured_unit(estimate, seconds):
    assert estimate.seconds == pytest.approx(seconds)


def test_candidate_regions_count_the_families():
    assert budget.candidate_regions((41, 41), ("bound",)) == 2 * 80
    assert budget.candidate_regions((41, 41), ("cell",)) == 41 * 41
    assert budget.candidate_regions((41, 41), ("disk", "box"), every=2, radii=3, half_widths=2) == 21 * 21 * 5


def _continuous_entry_points():
    """Each continuous entry point with a request beyond any machine, and a word its refusal must carry."""
    from mutual.constraints.continuous import (mppi_rollouts, point_model, rollout, soft_demonstrator,
                                               starts_around)
    small = _pendulum((11, 11), "sample")
    return [
        ("point_model", lambda: point_model(_pendulum((41, 41), "sample").replace(samples=10 ** 9)), "samples"),
        ("soft_demonstrator", lambda: soft_demonstrator(small, [], (10 ** 5, 10 ** 5)), "demonstrator cells"),
        ("mppi_rollouts", lambda: mppi_rollouts(small.replace(horizon=10 ** 9), [], np.full((100, 2), 0.1)),
         "demonstrations"),
        ("starts_around", lambda: starts_around([0.0, 0.0], [0.1, 0.1], 10 ** 12), "starts"),
        ("rollout", lambda: rollout(_Demonstrator(small.replace(horizon=10 ** 9)), np.full((100, 2), 0.1)),
         "demonstrations"),
    ]


class _Demonstrator:
    """Just enough of a SoftDemonstrator for :func:`rollout` to size its request."""
    def __init__(self, problem):
        self.problem = problem


@pytest.mark.parametrize("index", range(5), ids=["point_model", "soft_demonstrator", "mppi_rollouts",
                                                 "starts_around", "rollout"])
def test_continuous_entry_points_refuse_before_they_allocate(index):
    name, call, word = _continuous_entry_points()[index]
    message = _refused_quickly(call)
    assert word in message and ("GiB" in message or "TiB" in message), (name, message)
