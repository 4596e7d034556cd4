"""Figure 6.3's cell: five goals, the caption's three verdicts, and the centre goal's straight path by symmetry."""

import numpy as np
import pytest


def test_figure_63_cell_has_the_captions_three_verdicts():
    from mutual.motion.legible import multigoal
    goals, paths, plain = multigoal.figure_63_paths(N=20, every=10)
    measures = multigoal.figure_63_measures(goals, paths)
    assert list(measures["goal"]) == [f"Lambda_{i}" for i in range(1, 6)]
    assert measures["exterior"].tolist() == [True, False, False, False, True]
    assert set(multigoal.figure_63_verdicts(measures)) == {"exterior", "interior", "centre"}
    # by symmetry the centre goal's path from a start below it goes straight up
    assert np.abs(paths[2][:, 0]).max() < 1e-6
    with pytest.raises(ValueError, match="eta0 must be a negative"):
        multigoal.figure_63_paths(eta0=0.5)
