"""The chapter 3 scan's machinery: it keeps the chosen set-up, its statements use the claims' rules, and its
summary counts seeds and cells."""

import numpy as np
import pandas as pd

from mutual.compendium.claims import load_claims
from mutual.constraints import scan
from mutual.constraints.experiment import chapter3, scaled_cell


def test_the_scan_keeps_the_chosen_set_up():
    assert scan.CHOSEN.setup().grid.mdp.horizon == chapter3().grid.mdp.horizon == 18
    assert scaled_cell((4, 0), 9) == (4, 0) and scaled_cell((2, 6), 11) == (3, 8) and scaled_cell((6, 5), 7) == (5, 4)
    assert len(scan.full_scan()) == 60 and scan.CHOSEN in scan.full_scan() and len(scan.axes_scan()) == 10
    hot = scan.Setting(2.0).setup().grid.mdp
    np.testing.assert_allclose(hot.reward, 2 * chapter3().grid.mdp.reward)


def test_the_scan_statements_use_the_claims_rules():
    claims = load_claims().set_index("id")
    assert float(claims.loc["c3-f-bottom-middle", "thesis_value"]) == scan.F_BOTTOM_MIDDLE
    assert claims.loc["c3-f-bottom-middle", "compare"] == f"abs:{scan.F_BOTTOM_MIDDLE_TOL}"
    assert float(claims.loc["c3-f-retracts", "thesis_value"]) == scan.F_RETRACTS
    assert claims.loc["c3-f-retracts", "compare"] == f"abs:{scan.F_RETRACTS_TOL}"
    assert float(claims.loc["c3-gain-order-of-magnitude", "thesis_value"]) == scan.GAIN_DROP
    assert set(scan.STATEMENTS) <= set(claims.index)


def test_scan_summary_counts_seeds_and_cells():
    rows = [{"reward scale": b, "horizon": 18, "width": 9, "seed": s, "gain drop": 20.0 if (b == 1.0 or s < 5) else 2.0}
            for b in (1.0, 2.0) for s in range(10)]
    out = scan.scan_summary(pd.DataFrame(rows), scan.STATEMENTS["c3-gain-order-of-magnitude"], table_name="t")
    assert out["seeds"] == [10, 10] and out["settings"] == [1, 2] and "scale 2" in out["flips"]
