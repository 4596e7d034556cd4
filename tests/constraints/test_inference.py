"""Greedy constraint inference (Section 2.4): it recovers a known task-relevant ground truth from synthetic
demonstrations, stops by its rule, pools tasks as the average of their scores, and its candidates follow
the demonstrations; its bad inputs (tables)."""

import numpy as np
import pytest

from mutual.constraints.backup import rank_candidates
from mutual.constraints.chance import constraint_mask
from mutual.constraints.demonstrations import demonstration_log_likelihood, sample_demonstrations
from mutual.constraints.experiment import chapter3
from mutual.constraints.gridworld import GRID_ACTIONS, gridworld
from mutual.constraints.inference import constraint_candidates, greedy_inference, horizon_sensitivity


def test_candidates_feasibility_follows_the_demonstrations():
    g = gridworld(5, 4, (0, 0), (4, 0), slip=0.0)
    demos = sample_demonstrations(g.mdp, 10, rng=4)
    cand = constraint_candidates(g.mdp, demos, chance=False)
    used = np.zeros(9, dtype=bool)
    used[demos.actions.ravel()] = True
    visited = np.zeros(20, dtype=bool)
    visited[demos.states.ravel()] = True
    np.testing.assert_array_equal(cand.feasible[cand.kind == "action"], ~used)
    np.testing.assert_array_equal(cand.feasible[cand.kind == "state"], ~visited)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_greedy_inference_recovers_the_task_relevant_ground_truth(seed):
    # 9 x 9 gridworld: the bottom-middle state and two actions shape every demonstration;
    # the three upper-half states are too far from the task to matter (the blind spot).
    g = gridworld(9, 9, (0, 0), (8, 0), slip=0.1)
    upper = [g.state(2, 6), g.state(4, 7), g.state(6, 6)]
    nw, sw = GRID_ACTIONS.index("NW"), GRID_ACTIONS.index("SW")
    truth = constraint_mask(g.mdp, [g.state(4, 0)] + upper, 0.25, [nw, sw])
    demos = sample_demonstrations(g.mdp, 50, truth, rng=seed)
    cand = constraint_candidates(g.mdp, demos)
    relevant = {("state", g.state(4, 0)), ("action", nw), ("action", sw)}

    exact = greedy_inference(g.mdp, demos, cand, 3, criterion="likelihood")
    assert {(cand.kind[k], cand.index[k]) for k in exact.chosen} == relevant
    thesis = greedy_inference(g.mdp, demos, cand, 5, criterion="F")
    assert relevant <= {(cand.kind[k], cand.index[k]) for k in thesis.chosen}
    for result in (exact, thesis):
        assert np.isfinite(demonstration_log_likelihood(g.mdp, demos, result.mask))
        assert not set(result.chosen) & set(np.flatnonzero(~cand.feasible))


def test_stopping_rule_stops_when_the_gain_is_small():
    g = gridworld(5, 4, (0, 0), (4, 0), slip=0.1)
    demos = sample_demonstrations(g.mdp, 30, constraint_mask(g.mdp, [g.state(2, 0)], 0.25), rng=0)
    cand = constraint_candidates(g.mdp, demos)
    full = greedy_inference(g.mdp, demos, cand, 6)
    stopped = greedy_inference(g.mdp, demos, cand, 6, min_gain=0.05)
    n = full.n_accepted(0.05)
    assert stopped.chosen == full.chosen[:n]
    assert n == len(full.chosen) or full.gains[n] < 0.05


def test_horizon_sensitivity_reruns_round_one_per_horizon():
    from mutual.constraints.inference import horizon_sensitivity
    grid_at = lambda T: gridworld(5, 4, (0, 0), (4, 0), slip=0.1, horizon=T)  # noqa: E731
    g = grid_at(8)
    truth = constraint_mask(g.mdp, [g.state(2, 0)], 0.25)
    table = horizon_sensitivity(grid_at, [6, 8], truth, 30, 1, g.state(2, 0))
    assert list(table["horizon T"]) == [6, 8]
    demos = sample_demonstrations(g.mdp, 30, truth, rng=1)
    cand = constraint_candidates(g.mdp, demos)
    k = cand.find("state", g.state(2, 0))
    log_f, _ = rank_candidates(g.mdp, demos, cand.forbidden[:, :, [k]])
    row = table.iloc[1]
    assert row["F watched, round 1"] == pytest.approx(np.exp(log_f[0]), abs=1e-12)
    assert row["psi* watched"] == cand.psi[k] and row["F first choice"] <= row["F watched, round 1"]
    with pytest.raises(ValueError, match="horizons"):
        horizon_sensitivity(grid_at, [], truth, 30, 1, g.state(2, 0))


def test_latest_recovery_is_the_worst_case():
    from mutual.constraints.inference import latest_recovery
    assert latest_recovery([3, 5, 4]) == 5
    assert latest_recovery([3, "not reached"]) == "not reached"
    with pytest.raises(ValueError, match="rounds"):
        latest_recovery([])


def test_pooling_a_task_with_itself_changes_nothing():
    g = gridworld(6, 4, (0, 0), (5, 0), slip=0.1)
    demos = sample_demonstrations(g.mdp, 20, constraint_mask(g.mdp, [g.state(3, 0)], 0.25), rng=1)
    cand = constraint_candidates(g.mdp, demos)
    single = greedy_inference(g.mdp, demos, cand, 3)
    pooled = greedy_inference([g.mdp, g.mdp], [demos, demos], constraint_candidates([g.mdp, g.mdp], [demos, demos]), 3)
    assert pooled.chosen == single.chosen
    np.testing.assert_allclose(pooled.gains, single.gains, atol=1e-12)


def test_pooled_tasks_average_their_scores():
    a = gridworld(6, 4, (0, 0), (5, 0), slip=0.1)
    b = gridworld(6, 4, (0, 3), (5, 3), slip=0.1)
    da, db = sample_demonstrations(a.mdp, 10, rng=2), sample_demonstrations(b.mdp, 30, rng=3)
    cand = constraint_candidates([a.mdp, b.mdp], [da, db])
    result = greedy_inference([a.mdp, b.mdp], [da, db], cand, 1)
    idx = np.flatnonzero(cand.feasible)
    fa, ga = rank_candidates(a.mdp, da, cand.forbidden[:, :, idx])
    fb, gb = rank_candidates(b.mdp, db, cand.forbidden[:, :, idx])
    np.testing.assert_allclose(result.log_f[0][idx], (10 * fa + 30 * fb) / 40, atol=1e-12)
    np.testing.assert_allclose(result.gain[0][idx], (10 * ga + 30 * gb) / 40, atol=1e-12)


def test_stop_rule_fires_on_min_gain_and_says_so():
    g = gridworld(6, 4, (0, 0), (5, 0), slip=0.1)
    demos = sample_demonstrations(g.mdp, 30, constraint_mask(g.mdp, [g.state(3, 0)], 0.25), rng=0)
    cand = constraint_candidates(g.mdp, demos)
    full = greedy_inference(g.mdp, demos, cand, 5)
    cut = float(np.mean(full.gains[:2]))
    stopped = greedy_inference(g.mdp, demos, cand, 5, min_gain=cut)
    assert stopped.stop == "min_gain" and stopped.chosen == full.chosen[:full.n_accepted(cut)]
    assert "stopped by min_gain" in repr(stopped) and "[" in repr(stopped) and "array" not in repr(stopped)


def test_results_objects_print_short_summaries():
    g = gridworld(4, 4, (0, 0), (3, 0))
    demos = sample_demonstrations(g.mdp, 5, rng=0)
    cand = constraint_candidates(g.mdp, demos)
    result = greedy_inference(g.mdp, demos, cand, 2)
    for obj in (g, g.mdp, demos, cand, result):
        text = repr(obj)
        assert len(text) < 250 and "array" not in text and "\n" not in text, text


def test_until_stops_greedy_early_with_the_same_choices():
    first = chapter3("first")
    demos = sample_demonstrations(first.grid.mdp, 30, first.truth, rng=0)
    cand = constraint_candidates(first.grid.mdp, demos)
    full = greedy_inference(first.grid.mdp, demos, cand, 4)
    short = greedy_inference(first.grid.mdp, demos, cand, 4, until=lambda chosen: len(chosen) == 2)
    assert short.stop == "until" and short.chosen == full.chosen[:2]


G = gridworld(4, 4, (0, 0), (3, 0))
MDP0 = G.mdp
DEMOS = sample_demonstrations(MDP0, 5, rng=0)
CAND = constraint_candidates(MDP0, DEMOS)


def _greedy(**kwargs):
    args = dict(mdp=MDP0, demos=DEMOS, candidates=CAND, rounds=2)
    return greedy_inference(**{**args, **kwargs})


CASES = [
    # greedy inference (Section 2.4)
    (_greedy, (), dict(min_gain=float("nan")), ValueError, "min_gain"),
    (_greedy, (), dict(min_gain=float("inf")), ValueError, "min_gain"),
    (_greedy, (), dict(min_gain="0.1"), ValueError, "min_gain"),
    (_greedy, (), dict(rounds=-1), ValueError, "rounds"),
    (_greedy, (), dict(rounds=2.5), ValueError, "rounds"),
    (_greedy, (), dict(criterion="best"), ValueError, "criterion"),
    (_greedy, (), dict(criterion="likelihood", prune=True), ValueError, "prune"),
    (_greedy, (), dict(prune="yes"), TypeError, "prune"),
    (_greedy, (), dict(candidates="all"), TypeError, "candidates"),
    (_greedy, (), dict(engine="gpu"), ValueError, "engine"),
    (_greedy, (), dict(mdp=[MDP0, MDP0], demos=[DEMOS]), ValueError, "pooled"),
    (_greedy, (), dict(mdp=[MDP0, gridworld(5, 4, (0, 0), (4, 0)).mdp], demos=[DEMOS, DEMOS]), ValueError, "demonstrations"),
    (constraint_candidates, (MDP0, DEMOS), dict(chance="yes"), TypeError, "chance"),
    (horizon_sensitivity, (lambda T: G, [], MDP0.allowed, 5, 0, 1), {}, ValueError, "horizons"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i:02d}-{case[0].__name__}" for i, case in enumerate(CASES)])
def test_bad_input_raises_a_clear_error(fn, args, kwargs, error, phrase):
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value), f"message {str(info.value)!r} should mention {phrase!r}"
