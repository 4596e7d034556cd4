"""Chapter 3's set-up (loiter at the goal only, the layouts, pooled tasks), the non-causal and
greedy-versus-best checks, the Explore functions and the results objects' summaries."""

import numpy as np
import pytest
from matplotlib.figure import Figure

from mutual.constraints.backup import rank_candidates
from mutual.constraints.candidates import constraint_candidates
from mutual.constraints.chance import constraint_mask
from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.experiment import LAYOUTS, chapter3, measured_dynamics, rounds_table
from mutual.constraints.gridworld import GRID_ACTIONS, gridworld
from mutual.constraints.inference import greedy_inference
from mutual.constraints.mdp import MDP, soft_policy
from mutual.constraints.noncausal import causal_versus_noncausal
from mutual.constraints.subsets import BOUND, greedy_versus_best

LOITER = GRID_ACTIONS.index("loiter")


def test_loiter_is_offered_at_the_goal_only_by_default():
    g = gridworld(5, 4, (0, 0), (4, 0))
    goal = g.state(4, 0)
    assert g.mdp.allowed[:, LOITER].sum() == 1 and g.mdp.allowed[goal, LOITER]
    assert g.mdp.allowed[:, :LOITER].all()
    pi = soft_policy(g.mdp)
    assert np.all(pi[:, np.arange(20) != goal, LOITER] == 0)
    demos = sample_demonstrations(g.mdp, 200, rng=0)
    loitering = demos.actions == LOITER
    assert np.all(demos.states[:, :-1][loitering] == goal) and loitering.any()
    anywhere = gridworld(5, 4, (0, 0), (4, 0), loiter="anywhere")
    assert anywhere.mdp.allowed.all()
    assert measured_dynamics(g)["matches_text"] and not measured_dynamics(anywhere)["matches_text"]
    # the structural mask is part of every backup: the same mask with loiter allowed changes nothing
    everything = np.ones((20, 9), dtype=bool)
    np.testing.assert_array_equal(soft_policy(g.mdp, everything), pi)


def test_dense_transitions_round_trip_through_the_mdp():
    g = gridworld(3, 3, (0, 0), (2, 0))
    again = MDP(g.mdp.transitions, g.mdp.reward, g.mdp.horizon, g.mdp.terminal_reward, g.mdp.initial, g.mdp.allowed)
    np.testing.assert_array_equal(again.dense_transitions(), g.mdp.dense_transitions())


def test_layouts_are_fixed_and_layout_four_is_the_result():
    four, first, second = chapter3(), chapter3("first"), chapter3("second")
    assert four.layout is LAYOUTS["four"] and four.layout.task_relevant == 4 and first.layout.task_relevant == 3
    assert [GRID_ACTIONS[a] for a in four.actions] == ["NW", "W", "SW"] and four.upper == first.upper
    assert LAYOUTS["first"].upper == ((2, 6), (4, 7), (6, 5)) and LAYOUTS["second"].upper == ((2, 6), (4, 7), (6, 6))
    assert first.grid.coords(first.bottom_middle) == (4, 0)
    north = GRID_ACTIONS.index("N")
    assert not first.truth[first.grid.state(6, 4), north] and first.truth[first.grid.state(6, 5), north]
    assert second.truth[second.grid.state(6, 4), north] and not second.truth[second.grid.state(6, 5), north]
    assert "layout four" in repr(four) and "layout first" in repr(first) and len(repr(four)) < 300


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


def test_noncausal_distribution_matches_only_deterministic_dynamics():
    stochastic = causal_versus_noncausal(gridworld(2, 2, (0, 0), (1, 0), slip=0.2, horizon=2).mdp)
    deterministic = causal_versus_noncausal(gridworld(2, 2, (0, 0), (1, 0), slip=0.0, horizon=2).mdp)
    assert stochastic["dynamics_error_causal"] < 1e-12 < stochastic["dynamics_error_noncausal"]
    assert stochastic["kl"] > 1e-3 and deterministic["kl"] < 1e-12 and deterministic["policy_gap"] < 1e-12


def test_greedy_never_beats_the_best_subset_and_meets_the_bound_when_deterministic():
    g = gridworld(6, 5, (0, 0), (5, 0), slip=0.0)
    demos = sample_demonstrations(g.mdp, 10, constraint_mask(g.mdp, [g.state(3, 0)], 0.0), rng=4)
    cand = constraint_candidates(g.mdp, demos, chance=False)
    rows, violations = greedy_versus_best(g.mdp, demos, cand, 2)
    assert rows and violations == 0
    for r in rows:
        assert r["greedy"] <= r["best"] + 1e-12 and r["ratio"] >= BOUND
    # k = 1: greedy is exhaustive, and its removed mass is 1 - F of the smallest-F candidate (eq. 2.25)
    log_f, gain = rank_candidates(g.mdp, demos, cand.forbidden[:, :, cand.feasible])
    assert rows[0]["greedy"] == pytest.approx(rows[0]["best"])
    assert rows[0]["greedy"] == pytest.approx(1 - np.exp(np.nanmin(np.where(np.isfinite(gain), log_f, np.nan))))


def _image(fig):
    return [im.get_array().filled(np.nan) for ax in fig.axes for im in ax.get_images()]


def test_explore_views_are_figures_that_follow_their_inputs():
    from mutual.constraints import explore
    a, b = explore.demonstrations_view(25, 0.1), explore.demonstrations_view(25, 0.3)
    assert isinstance(a, Figure) and isinstance(b, Figure)
    assert any(not np.array_equal(x, y, equal_nan=True) for x, y in zip(_image(a), _image(b)))
    assert "25 simulated demos" in a.axes[0].get_title()
    r1, r2 = explore.inference_round_view(1, 25, 0.1), explore.inference_round_view(2, 25, 0.1)
    assert r1.axes[0].get_title() != r2.axes[0].get_title()


def test_inference_animation_has_a_frame_per_round(tmp_path):
    from mutual.constraints import explore
    from mutual.constraints.plots import inference_animation
    setup, demos, cand, result = explore.inference_run(25, 0.1)
    anim = inference_animation(setup.grid, cand, result, setup.states, setup.actions, hold=1)
    path = tmp_path / "anim.gif"
    anim.save(path, writer="pillow", dpi=40)
    from PIL import Image
    assert Image.open(path).n_frames >= 2
    table = rounds_table(setup.grid, cand, result, setup.candidate_ids(cand)[2], "test")
    assert len(table) == len(result.chosen) and table["F"].between(0, 1).all()


def test_results_objects_print_short_summaries():
    g = gridworld(4, 4, (0, 0), (3, 0))
    demos = sample_demonstrations(g.mdp, 5, rng=0)
    cand = constraint_candidates(g.mdp, demos)
    result = greedy_inference(g.mdp, demos, cand, 2)
    for obj in (g, g.mdp, demos, cand, result):
        text = repr(obj)
        assert len(text) < 250 and "array" not in text and "\n" not in text, text
