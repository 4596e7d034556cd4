"""The inference figure (mutual.constraints.continuous.plots) and the command's progress bar, checked on the
drawn artists: a disk is a circle of its radius on equal axes, every inferred region carries its round,
the title is wrapped, and the bar ends at 100 % however the run ends."""

import textwrap
from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402

from mutual.constraints.continuous import Bound, Disk, Grid  # noqa: E402
from mutual.constraints.continuous.plots import inference_figure  # noqa: E402

GRID = Grid.uniform([-3, -2, -np.pi], [4, 2, np.pi], [14, 8, 12], [False, False, True], ("x", "y", "heading"),
                    ("m", "m", "rad"))


def fake_inference(regions, labels):
    """Only what the figure reads: the problem's grid, the states, the regions and their labels."""
    states = np.stack([np.c_[np.linspace(-2.5, 2.5, 11), np.full(11, y), np.zeros(11)] for y in (-1.0, 1.0)])
    return SimpleNamespace(problem=SimpleNamespace(grid=GRID), states=states, chosen_regions=lambda: regions,
                           labels=lambda: labels)


def test_a_disk_is_a_circle_on_equal_axes_and_every_region_carries_its_round():
    regions = [Disk((0, 1), (0.25, -0.1), 0.8), Bound(1, "upper", 1.5), Bound(2, "lower", -1.0)]
    fig = inference_figure(fake_inference(regions, ["a disk", "a bound", "a heading bound"]))
    plane, second = fig.axes[:2]
    circles = [p for p in plane.patches if isinstance(p, Circle)]
    assert len(circles) == 1 and circles[0].radius == pytest.approx(0.8) and circles[0].center == pytest.approx((0.25, -0.1))
    assert plane.get_aspect() == 1.0 and second.get_aspect() != 1.0          # x, y share metres; y, heading do not
    numbers = sorted(t.get_text() for ax in fig.axes for t in ax.texts)
    assert numbers == ["1", "2", "2", "3"]                                    # the y bound appears in both panels


def test_the_title_is_wrapped_and_lists_every_round():
    labels = [f"disk at (x, y) = ({k}.123, -0.456), radius 0.789 m" for k in range(6)]
    fig = inference_figure(fake_inference([Disk((0, 1), (k * 0.1, 0.0), 0.3) for k in range(6)], labels), width=80)
    title = fig._suptitle.get_text()
    assert all(len(line) <= 80 for line in title.splitlines()) and len(title.splitlines()) > 1
    assert title.replace("\n", " ") == " ".join(textwrap.wrap("inferred, by round: " + "; ".join(
        f"{n}: {label}" for n, label in enumerate(labels, 1)), 80))


def test_the_command_s_progress_bar_ends_at_100_percent_when_the_stop_rule_ends_the_run(tmp_path, capsys, monkeypatch):
    """A run that stops after its first round (the stop rule) still ends its bar at 100 %."""
    from pathlib import Path

    from mutual.cli import main
    examples = Path(__file__).resolve().parents[3] / "data" / "examples"
    monkeypatch.setenv("TQDM_DISABLE", "0")
    assert main(["constraints", "infer-continuous", str(examples / "pendulum_trajectories.csv"), "--system",
                 str(examples / "pendulum.toml"), "--cells", "13", "--rounds", "3", "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert "100%" in err.splitlines()[-1] or "100%" in err.split("\r")[-1], err[-300:]
