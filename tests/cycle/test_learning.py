"""Learning in the cycle: pooled inference against the library's greedy inference and concatenated
demonstrations, the stopping rule against its closed form, relevance against sampling; bad inputs
(a table)."""

import numpy as np
import pytest
from scipy import stats

from mutual.constraints.backup import rank_candidates
from mutual.constraints.chance import constraint_mask
from mutual.constraints.demonstrations import Demonstrations, sample_demonstrations
from mutual.constraints.gridworld import GRID_ACTIONS, gridworld
from mutual.constraints.inference import constraint_candidates, greedy_inference
from mutual.constraints.mdp import soft_policy
from mutual.cycle.learning import (ConstraintSet, concatenate, per_demo_log_likelihood, pooled_inference, relevance,
                                   sample_efficiency, scores, stop_threshold)
from mutual.cycle.outcomes import rollout_outcomes, sample_rollouts


@pytest.fixture(scope="module")
def world():
    g1 = gridworld(6, 6, start=(0, 0), goal=(5, 0), slip=0.1)
    g2 = gridworld(6, 6, start=(0, 4), goal=(5, 4), slip=0.1)
    truth = ConstraintSet([g1.state(2, 0), g1.state(3, 4)], 0.25, [GRID_ACTIONS.index("SW")])
    d1 = sample_demonstrations(g1.mdp, 60, truth.mask(g1.mdp), rng=3)
    d2 = sample_demonstrations(g2.mdp, 60, truth.mask(g2.mdp), rng=4)
    return g1, g2, truth, d1, d2


def test_constraint_set_mask_is_eq_3_2(world):
    g1, _, truth, _, _ = world
    expected = constraint_mask(g1.mdp, list(truth.states), 0.25, list(truth.actions))
    np.testing.assert_array_equal(truth.mask(g1.mdp), expected)
    assert truth.without(("state", g1.state(2, 0))).states == (g1.state(3, 4),)
    assert truth.only(("action", GRID_ACTIONS.index("SW"))).actions == (GRID_ACTIONS.index("SW"),)


def test_single_task_pooled_inference_is_the_library_greedy_inference(world):
    g1, _, _, d1, _ = world
    cand = constraint_candidates(g1.mdp, d1)
    ours = pooled_inference([(g1.mdp, d1)], max_rounds=5, level=None, candidates=cand)
    library = greedy_inference(g1.mdp, d1, cand, 5, criterion="likelihood")
    assert ours.chosen == library.chosen
    np.testing.assert_allclose(ours.total_gain, d1.n * library.exact_gains, rtol=1e-10)
    np.testing.assert_array_equal(ours.mask, library.mask)


def test_pooling_a_task_with_itself_equals_concatenated_demonstrations(world):
    g1, _, _, d1, _ = world
    half = [Demonstrations(d1.states[:30], d1.actions[:30]), Demonstrations(d1.states[30:], d1.actions[30:])]
    pooled = pooled_inference([(g1.mdp, half[0]), (g1.mdp, half[1])], max_rounds=4, level=None)
    whole = pooled_inference([(g1.mdp, concatenate(half))], max_rounds=4, level=None)
    assert pooled.chosen == whole.chosen
    np.testing.assert_allclose(pooled.total_gain, whole.total_gain, rtol=1e-10)


def test_stop_threshold_is_half_the_normal_quantile_squared():
    for level in (0.9, 0.95, 0.99):
        assert stop_threshold(level) == pytest.approx(0.5 * stats.norm.ppf(0.5 + level / 2) ** 2, rel=1e-10)


def test_the_stopping_rule_stops_exactly_when_the_best_gain_falls_below_the_threshold(world):
    g1, g2, _, d1, d2 = world
    run = pooled_inference([(g1.mdp, d1), (g2.mdp, d2)], max_rounds=20, level=0.95)
    assert run.stopped and np.all(run.total_gain >= stop_threshold(0.95))
    rest = np.flatnonzero(run.candidates.feasible & ~np.isin(np.arange(len(run.candidates)), run.chosen))
    total = sum(d.n * rank_candidates(m, d, run.candidates.forbidden[:, :, rest], run.mask)[1]
                for m, d in ((g1.mdp, d1), (g2.mdp, d2)))
    assert np.max(total) < stop_threshold(0.95)


def test_pooling_fills_the_first_tasks_blind_spot(world):
    g1, g2, truth, d1, d2 = world
    rel2 = [k for k, p in relevance(g2.mdp, truth).items() if p >= 0.1]
    alone = pooled_inference([(g1.mdp, d1)], level=0.95)
    both = pooled_inference([(g1.mdp, d1), (g2.mdp, d2)], level=0.95)
    assert scores(both.labels, truth, rel2)["recall_relevant"] > scores(alone.labels, truth, rel2)["recall_relevant"]


def test_relevance_agrees_with_sampled_demonstrators(world):
    g1, _, truth, _, _ = world
    exact = relevance(g1.mdp, truth)
    for label, p in exact.items():
        mdp = g1.mdp
        rolls = sample_rollouts(mdp, soft_policy(mdp, truth.without(label).mask(mdp)), 4000, rng=11)
        sampled = rollout_outcomes(mdp, rolls, allowed=truth.only(label).mask(mdp))["p_break"]
        assert abs(sampled - p) < 5 * np.sqrt(p * (1 - p) / 4000) + 1e-9, label
    assert exact[("state", g1.state(2, 0))] > 0.1 > exact[("state", g1.state(3, 4))]


def test_per_demo_log_likelihood_sums_to_the_library_total(world):
    from mutual.constraints.demonstrations import demonstration_log_likelihood
    g1, _, truth, d1, _ = world
    mask = truth.mask(g1.mdp)
    assert per_demo_log_likelihood(g1.mdp, d1, mask).sum() == pytest.approx(
        demonstration_log_likelihood(g1.mdp, d1, mask), rel=1e-12)
    assert np.all(np.isneginf(per_demo_log_likelihood(g1.mdp, d1, np.zeros_like(mask))))


def test_scores():
    truth = ConstraintSet((1, 2), 0.2, (3,))
    s = scores([("state", 1), ("state", 9)], truth, [("state", 1), ("action", 3)])
    assert (s["precision"], s["recall_relevant"], s["recall_all"]) == (0.5, 0.5, pytest.approx(1 / 3))
    assert np.isnan(scores([], truth, [("state", 1)])["precision"])


def test_sample_efficiency_rows(world):
    g1, _, truth, _, _ = world
    rel = [k for k, p in relevance(g1.mdp, truth).items() if p >= 0.1]
    df = sample_efficiency(g1.mdp, truth, [5, 40], [0, 1], rel, n_heldout=50)
    assert len(df) == 4 and set(df["n_demos"]) == {5, 40}
    assert np.all(df["loglik_truth"] > df["loglik_none"])          # the truth explains the data better than nothing
    assert np.all((df["heldout_allowed"] >= 0) & (df["heldout_allowed"] <= 1))


def test_two_task_pooled_inference_is_the_library_pooled_greedy_inference(world):
    g1, g2, _, d1, d2 = world
    ours = pooled_inference([(g1.mdp, d1), (g2.mdp, d2)], max_rounds=5, level=None)
    library = greedy_inference([g1.mdp, g2.mdp], [d1, d2], ours.candidates, 5, criterion="likelihood")
    assert ours.chosen == library.chosen
    np.testing.assert_allclose(ours.total_gain, (d1.n + d2.n) * library.exact_gains, rtol=1e-10)


GRID = gridworld(3, 3, start=(0, 0), goal=(2, 0), slip=0.1, horizon=4)
MDP = GRID.mdp
T, X, A = MDP.horizon, MDP.n_states, MDP.n_actions
DEMOS = Demonstrations(np.full((2, T + 1), GRID.state(*GRID.goal)), np.full((2, T), 8))      # loiter at the goal
OTHER_GRID = gridworld(4, 4, start=(0, 0), goal=(3, 0), horizon=4)
OTHER, OTHER_DEMOS = OTHER_GRID.mdp, Demonstrations(np.full((2, 5), OTHER_GRID.state(3, 0)), np.full((2, 4), 8))


CASES = [
    (ConstraintSet, ((1, 2), 1.5), {}, ValueError, "psi"),
    (stop_threshold, (1.0,), {}, ValueError, "level"),
    (concatenate, ([],), {}, ValueError, "demos_list"),
    (pooled_inference, ([],), {}, ValueError, "tasks"),
    (pooled_inference, ([(MDP, DEMOS)],), {"max_rounds": -1}, ValueError, "max_rounds"),
    (pooled_inference, ([(MDP, DEMOS), (OTHER, OTHER_DEMOS)],), {}, ValueError, "share"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{c[0].__name__ if hasattr(c[0], '__name__') else 'call'}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase):
        fn(*args, **kwargs)
