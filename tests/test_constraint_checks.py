"""Chapters 2-3's statements checked by independent routes (issue 20): eq. 2.8 by finite differences, eq. 2.23 by
enumerating feedback controllers, Lemma 3.2.1 on the exact likelihood, the greedy bound where greedy is not
optimal, and the chapter 3 scan's machinery."""

import numpy as np
import pandas as pd
import pytest

from mutual.compendium.claims import load_claims
from mutual.constraints import scan
from mutual.constraints.chance import constraint_mask, lemma_321_exact, threshold_levels
from mutual.constraints.complexity import gridworld_ranking_work
from mutual.constraints.controllers import controller_check, random_mdp
from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.experiment import chapter3, scaled_cell
from mutual.constraints.gradient import gradient_check, reward_model
from mutual.constraints.gridworld import gridworld
from mutual.constraints.inference import greedy_inference
from mutual.constraints.candidates import constraint_candidates
from mutual.constraints.subsets import BOUND, greedy_bound_survey


@pytest.mark.parametrize("horizon", [1, 2, 3])
def test_eq223_holds_for_deterministic_dynamics(horizon):
    out = controller_check(random_mdp(3, 2, horizon, deterministic=True, seed=horizon))
    assert out["max_gap"] < 1e-12 and out["eq223_total"] == pytest.approx(1, abs=1e-12)


def test_eq223_is_no_distribution_under_stochastic_dynamics():
    out = controller_check(random_mdp(3, 2, 2, deterministic=False, seed=0))
    assert out["causal_total"] == pytest.approx(1, abs=1e-12)  # the causal model is one
    assert out["controllers"] == 16 and out["eq223_total"] > 1.5 and out["max_gap"] > 0.05
    # one step: a controller is one action, and eq. 2.23 is eq. 2.19
    assert controller_check(random_mdp(3, 2, 1, deterministic=False, seed=0))["max_gap"] < 1e-12


def test_eq28_matches_finite_differences_for_deterministic_dynamics():
    g = gridworld(4, 3, (0, 0), (3, 0), slip=0.0, horizon=6)
    phi = np.random.default_rng(0).random((g.mdp.n_states, g.mdp.n_actions, 2))
    theta = np.array([-1.0, 0.5])
    demos = sample_demonstrations(reward_model(g.mdp, phi, theta), 50, rng=1)
    analytic, numeric, gap = gradient_check(g.mdp, phi, theta, demos)
    assert gap < 1e-7 and np.abs(analytic).max() > 1e-3
    with pytest.raises(ValueError, match="theta"):
        gradient_check(g.mdp, phi, [1.0], demos)


def test_lemma_321_holds_on_deterministic_dynamics():
    g = gridworld(4, 3, (0, 0), (3, 0), slip=0.0, horizon=6)
    demos = sample_demonstrations(g.mdp, 30, constraint_mask(g.mdp, [g.state(1, 0)], 0.0), rng=2)
    table = lemma_321_exact(g.mdp, demos)
    assert len(table) and table["holds"].all()


def test_lemma_321_fails_on_the_exact_likelihood_with_slip():
    """The reading of issue 20 on the earlier three-truth layout: cell (2, 6) loses about 7e-5 nats per demonstration."""
    first = chapter3("first")
    demos = sample_demonstrations(first.grid.mdp, 100, first.truth, rng=0)
    row = lemma_321_exact(first.grid.mdp, demos, states=[first.grid.state(2, 6)]).iloc[0]
    assert not row["holds"] and row["gain at lowest"] == pytest.approx(-7.5e-5, rel=0.05)
    assert row["best psi"] >= max(threshold_levels(first.grid.mdp, first.grid.state(2, 6))[:-1])


def test_the_greedy_bound_is_tested_where_greedy_falls_short():
    survey = greedy_bound_survey(12, k_max=3, seed=0)
    assert survey["suboptimal"].any(), "no instance where greedy is sub-optimal: the bound would go untested"
    assert survey["ratio"].min() >= BOUND


def test_algorithm_3_and_1_counted_work():
    T, A, n = 20, 9, 6
    X = n * n
    assert gridworld_ranking_work(n, algorithm=3) == T * X ** 2 * A * (X + A + 1)
    assert gridworld_ranking_work(n, algorithm=1) == 2 * T * X ** 2 * A  # one backup, one forward pass


def test_the_scan_keeps_the_chosen_set_up():
    assert scan.CHOSEN.setup().grid.mdp.horizon == chapter3().grid.mdp.horizon == 18
    assert scaled_cell((4, 0), 9) == (4, 0) and scaled_cell((2, 6), 11) == (3, 8) and scaled_cell((6, 5), 7) == (5, 4)
    cells = scan.grid_scan()
    assert len(cells) == 12 * 8 * 4 * 4 == len(set(cells)) and scan.CHOSEN in cells and len(scan.axes_scan()) == 25
    assert set(scan.axes_scan()) <= set(cells)
    hot = scan.Setting(2.0).setup().grid.mdp
    np.testing.assert_allclose(hot.reward, 2 * chapter3().grid.mdp.reward)


def test_the_scan_statements_use_the_claims_rules():
    claims = load_claims().set_index("id")
    assert float(claims.loc["c3-f-bottom-middle", "thesis_value"]) == scan.F_BOTTOM_MIDDLE
    assert claims.loc["c3-f-bottom-middle", "compare"] == f"abs:{scan.F_BOTTOM_MIDDLE_TOL}"
    assert float(claims.loc["c3-f-retracts", "thesis_value"]) == scan.F_RETRACTS
    assert claims.loc["c3-f-retracts", "compare"] == f"abs:{scan.F_RETRACTS_TOL}"
    assert float(claims.loc["c3-gain-order-of-magnitude", "thesis_value"]) == scan.GAIN_DROP
    assert set(scan.STATEMENTS) | {scan.BLINDSPOT_STATEMENT[0]} <= set(claims.index)
    assert all(claims.loc[c, "basis"] == "computed" for c in scan.STATEMENTS)


def test_scan_summary_counts_seeds_and_cells():
    rows = [{"layout": "four", "reward scale": b, "horizon": 18, "width": 9, "seed": s,
             "gain drop": 20.0 if (b == 1.0 or s < 1) else 2.0} for b in (1.0, 2.0) for s in range(3)]
    chosen = [{"layout": "four", "reward scale": 1.0, "horizon": 18, "width": 9, "seed": s,
               "gain drop": 20.0 if s != 4 else 2.0} for s in range(10)]
    out = scan.scan_summary(pd.DataFrame(rows), scan.STATEMENTS["c3-gain-order-of-magnitude"], pd.DataFrame(chosen),
                            table_name="t")
    assert out["seeds"] == [9, 10] and out["settings"] == [1, 2] and "scale 2" in out["flips"] and out["table"] == "t"
    with pytest.raises(ValueError, match="chosen"):
        scan.scan_summary(pd.DataFrame(rows), scan.STATEMENTS["c3-gain-order-of-magnitude"], pd.DataFrame(rows[3:]))


def test_until_stops_greedy_early_with_the_same_choices():
    first = chapter3("first")
    demos = sample_demonstrations(first.grid.mdp, 30, first.truth, rng=0)
    cand = constraint_candidates(first.grid.mdp, demos)
    full = greedy_inference(first.grid.mdp, demos, cand, 4)
    short = greedy_inference(first.grid.mdp, demos, cand, 4, until=lambda chosen: len(chosen) == 2)
    assert short.stop == "until" and short.chosen == full.chosen[:2]
