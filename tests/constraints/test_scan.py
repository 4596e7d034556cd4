"""The chapter 3 scan's machinery (mutual.constraints.scan): it keeps the chosen set-up, its statements use the
claims' rules, its summary counts seeds and cells, and a run's numbers equal the one-run greedy's own summary."""

import numpy as np
import pandas as pd
import pytest

from mutual.compendium.claims import load_claims
from mutual.constraints import scan
from mutual.constraints.candidates import constraint_candidates
from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.experiment import chapter3, scaled_cell
from mutual.constraints.inference import greedy_inference
from mutual.constraints.layouts import layout_family


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


def test_a_runs_numbers_match_the_one_run_greedy():
    setting = scan.Setting(2.0, 2.0, 7, layout_family()[0])
    row = scan.world_rows([setting], [0], n_demos=60)[0]
    setup = setting.setup()
    demos = sample_demonstrations(setup.grid.mdp, 60, setup.truth, rng=0)
    cand = constraint_candidates(setup.grid.mdp, demos)
    result = greedy_inference(setup.grid.mdp, demos, cand, len(row["chosen"].split("; ")))
    relevant, upper, truth = setup.candidate_ids(cand)
    summary = result.summary(relevant, truth)
    assert row["chosen"] == "; ".join(setup.grid.label(cand.kind[k], cand.index[k]) for k in result.chosen)
    assert row["recovered at"] == summary["recovered_at"] and row["next untrue"] == summary["next_untrue"]
    assert row["F next"] == pytest.approx(summary["F_next"], abs=1e-12)
    assert row["gain drop"] == pytest.approx(summary["gain_drop"], rel=1e-9)
    assert row["F bottom-middle"] == pytest.approx(np.exp(result.log_f[0][relevant[0]]), abs=1e-12)
    assert row["first is bottom-middle"] == (result.chosen[0] == relevant[0])
    assert row["upper feasible"] == sum(np.isfinite(result.gain[0][k]) for k in upper)
    rejects = (cand.kind == "state") & ~np.isfinite(result.gain[0]) & (cand.psi < 1)
    assert row["psi* rejects"] == int(rejects.sum())
    untrue = next((i + 1 for i, k in enumerate(result.chosen) if k not in truth), None)
    assert row["first untrue at"] == untrue
