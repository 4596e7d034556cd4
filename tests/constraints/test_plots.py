"""Figure 3.3's candidate maps (mutual.constraints.plots): on the gain scale every candidate is shaded by -log F on
one logarithmic scale, so candidates whose F all lie near 1 still differ."""

import numpy as np
import pytest
from matplotlib.colors import LogNorm

from mutual.constraints.candidates import constraint_candidates
from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.experiment import chapter3
from mutual.constraints.inference import greedy_inference
from mutual.constraints.plots import GAIN_FLOOR, inference_panels, round_values


def test_the_gain_scale_shows_minus_log_f_on_a_log_norm():
    setup = chapter3(width=7, horizon=14)
    demos = sample_demonstrations(setup.grid.mdp, 30, setup.truth, rng=0)
    cand = constraint_candidates(setup.grid.mdp, demos)
    result = greedy_inference(setup.grid.mdp, demos, cand, 3)
    gains = round_values(result, 2, "gain")
    finite = np.isfinite(result.log_f[2])
    np.testing.assert_allclose(gains[finite], np.maximum(-result.log_f[2][finite], GAIN_FLOOR))
    fig = inference_panels(setup.grid, cand, result, [1, 2], setup.states, setup.actions, scale="gain")
    images = [im for ax in fig.axes for im in ax.get_images()]
    assert images and all(isinstance(im.norm, LogNorm) for im in images)
    state_image = [im.get_array() for im in images if im.get_array().shape == (7, 7)][-1]
    states = cand.kind == "state"
    np.testing.assert_allclose(state_image.filled(np.nan).ravel(), gains[states], equal_nan=True)
    assert len({im.norm.vmax for im in images}) == 1          # one scale for every panel
    with pytest.raises(ValueError, match="scale"):
        round_values(result, 0, "log")
