"""The scans of what the thesis leaves open: Figure 7.2's scan solves both hazards for every alpha, and
Figure 6.1's scan rows."""

import numpy as np

from mutual.motion.evident import safety as es


def test_figure_72_scan_solves_both_hazards_for_every_alpha():
    from mutual.motion.evident import scans
    table, paths = scans.figure_72_scan([0.5, 1.0], [[-2.0, 2.0], [2.0, -2.0]], steps=20)
    assert len(table) == 4 and set(table["hazard"]) == {"[-2.0, 2.0]", "[2.0, -2.0]"}
    assert {"obvious", "anticipates", "H1 only slightly", "feature legible"} <= set(table.columns)
    assert set(paths[(2.0, -2.0)]) == {"H0", "H1", 0.5, 1.0}
    same = es.solve(es.figure_scenario("7.2", steps=20)[0], es.figure_scenario("7.2", steps=20)[2])
    np.testing.assert_allclose(paths[(-2.0, 2.0)]["H1"].xs, same.xs)       # the chosen cell is the notebook's solve


def test_figure_61_scan_rows():
    from mutual.motion.evident import scans
    table = scans.figure_61_scan((10.0,), (5.0, 20.0), (0.5,), steps=20)
    assert len(table) == 2 and table["H0 collides"].all()                   # the person stands on H0's course
    assert (table["H1 closest"] > 0).all() and table["error"].eq("").all()
