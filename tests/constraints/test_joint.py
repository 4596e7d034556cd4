"""Chapter 3's joint search and the scan's ranges (mutual.constraints.joint): the distance from the thesis by hand,
the ranking and the refinement's cells, the demonstrator's saturation, and the calibrated reward scale."""

import numpy as np
import pandas as pd
import pytest

from mutual.constraints import joint, scan
from mutual.constraints.layouts import layout_family


def test_the_distance_counts_tolerances_by_hand():
    row = {"F bottom-middle": 0.39, "F first untrue": 0.99, "first untrue at": 3, "recovered at": None}
    terms = joint.distance_terms(row, rounds=8)
    assert terms == pytest.approx({"F bottom-middle": 2.0, "F retraction": 1.0, "retraction round": 2, "recovery round": 5})
    perfect = {"F bottom-middle": 0.29, "F first untrue": 0.96, "first untrue at": 5, "recovered at": 4}
    assert joint.distance(perfect) == pytest.approx(0, abs=1e-12)
    assert joint.distance({**perfect, "F bottom-middle": np.nan}) == pytest.approx(0.71 / 0.05)


def test_ranking_and_refinement():
    rows = [{"layout": "four", "reward scale": b, "horizon": 18, "width": 9, "seed": s, "at goal": 1.0,
             "F bottom-middle": f, "F first untrue": 0.96, "first untrue at": 5, "recovered at": 4}
            for b, f in ((1.0, 0.5), (4.0, 0.3)) for s in range(2)]
    ranked = joint.rank_setups(pd.DataFrame(rows))
    assert list(ranked["reward scale"]) == [4.0, 1.0] and ranked["distance"].iloc[0] == pytest.approx(0.2)
    cells = joint.refinement(ranked, layout_family(), top=1)
    assert [round(c.reward_scale, 6) for c in cells] == [round(4 / 2 ** 0.5, 6), 4.0, round(4 * 2 ** 0.5, 6)]
    assert all(c.horizon == 18 and c.width == 9 and c.layout.name == "four" for c in cells)
    assert joint.best_setup(ranked)["reward scale"] == 4.0


def test_the_demonstrator_saturates_as_it_cools():
    table = joint.saturation_table(layout_family()[0], (1.0, 8.0, 16.0), (2.0,), (7,))
    moves = table["moves"].to_numpy()
    assert moves[0] > moves[1] >= 6 and table["moves change"].iloc[1] < 0.01 < table["moves change"].iloc[0]
    assert table["entropy per move"].is_monotonic_decreasing and table["at goal"].between(0, 1).all()


def test_the_calibrated_scale_gives_the_thesis_f_for_the_bottom_middle_cell():
    scale = joint.calibrated_scale(2.0, 9)
    assert joint.bottom_middle_f(scale, 2.0, 9) == pytest.approx(scan.F_BOTTOM_MIDDLE, abs=1e-6)
    assert joint.bottom_middle_f(scale / 2, 2.0, 9) > scan.F_BOTTOM_MIDDLE > joint.bottom_middle_f(scale * 2, 2.0, 9)
    # the same F as greedy inference's round 1 on demonstrations that stand beside the cell
    setting = scan.Setting(scale, 2.0, 9, layout_family()[0])
    row = scan.world_rows([setting], [0])[0]
    assert row["F bottom-middle"] == pytest.approx(scan.F_BOTTOM_MIDDLE, abs=1e-6)
    assert joint.calibrated_scale(2.0, 9, target=0.999) == 0.125
