"""Notebook 01-02's Explore views and the inference animation: figures whose content follows their inputs,
one frame per round; their bad inputs (a table)."""

import numpy as np
import pytest
from matplotlib.figure import Figure

from mutual.constraints.experiment import rounds_table
from mutual.constraints.explore import inference_round_view, inference_run


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


CASES = [
    # explore
    (inference_round_view, (), dict(round=0), ValueError, "round"),
    (inference_run, (), dict(n_demos=0), ValueError, "n_demos"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i:02d}-{case[0].__name__}" for i, case in enumerate(CASES)])
def test_bad_input_raises_a_clear_error(fn, args, kwargs, error, phrase):
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value), f"message {str(info.value)!r} should mention {phrase!r}"
