"""Saving figures and tables: byte-identical across runs, and the names checked (a figure's name is its
thesis number)."""

import hashlib
import subprocess
import sys
import textwrap

import pandas as pd
import pytest

from mutual.compendium.figures import save_animation, save_table, savefig


FIGURE_SCRIPT = textwrap.dedent("""
    import numpy as np, matplotlib.pyplot as plt
    from mutual.compendium.figures import use_style, savefig
    use_style()
    fig, ax = plt.subplots()
    ax.plot(np.linspace(0, 1, 50) ** 2, label="a")
    ax.contourf(np.random.default_rng(0).random((5, 5)))
    ax.legend()
    savefig(fig, "fig_9_1")
    from matplotlib.animation import FuncAnimation
    from mutual.compendium.figures import save_animation
    line, = ax.plot([], [])
    save_animation(FuncAnimation(fig, lambda k: line.set_data(np.arange(k), np.arange(k)), frames=8), "anim_9_1")
""")


def _digests(folder):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


def test_figures_are_byte_identical_across_runs(tmp_path):
    digests = []
    for run in ("a", "b"):
        out = tmp_path / run
        env = {**__import__("os").environ, "MUTUAL_OUTPUT_DIR": str(out), "MPLBACKEND": "Agg"}
        env.pop("SOURCE_DATE_EPOCH", None)
        subprocess.run([sys.executable, "-c", FIGURE_SCRIPT], env=env, check=True)
        digests.append(_digests(out))
    assert set(digests[0]) == {"fig_9_1.pdf", "fig_9_1.png", "anim_9_1.gif"}
    assert digests[0] == digests[1]


def test_figure_and_table_names_are_checked(tmp_path, monkeypatch):
    monkeypatch.setenv("MUTUAL_OUTPUT_DIR", str(tmp_path))
    with pytest.raises(ValueError, match="fig_3_1"):
        savefig(None, "figure3")
    with pytest.raises(ValueError, match="table"):
        save_table(pd.DataFrame({"a": [1]}), "fig_5_1")
    save_table(pd.DataFrame({"set": ["Standard"], "fp": [1.25]}), "table_9_1")
    with pytest.raises(ValueError, match="anim"):
        save_animation(None, "fig_9_1")
    assert (tmp_path / "table_9_1.md").read_text().splitlines()[0] == "| set | fp |"



def test_a_quick_run_saves_the_png_alone(tmp_path, monkeypatch):
    """The runner's --quick (the tests' notebook lane) writes the PNG and no PDF; a full run writes both. (Not
    the same PNG bytes: a full run draws the PDF first, which can move the tight box by a pixel.)"""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    for mode in ("full", "quick"):
        monkeypatch.setenv("MUTUAL_OUTPUT_DIR", str(tmp_path / mode))
        monkeypatch.setenv("MUTUAL_RUN_MODE", mode)
        fig, ax = plt.subplots()
        ax.plot([0, 1, 4])
        savefig(fig, "fig_9_2")
        plt.close(fig)
    assert sorted(p.name for p in (tmp_path / "full").iterdir()) == ["fig_9_2.pdf", "fig_9_2.png"]
    assert sorted(p.name for p in (tmp_path / "quick").iterdir()) == ["fig_9_2.png"]
    assert (tmp_path / "quick" / "fig_9_2.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
