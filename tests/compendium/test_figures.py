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


def test_only_a_quick_run_saves_the_png_alone(tmp_path, monkeypatch):
    """The runner's --quick (the tests' notebook lane) writes the PNG and no PDF; a full or custom run of the runner,
    and a lab or script (no runner), write both. (Drawing the PDF first can change a PNG's bytes, so a quick run's
    PNG is checked as a PNG, not against a full run's.)"""
    import matplotlib.pyplot as plt
    from mutual.compendium.runs import ENV_MODE, ENV_NOTEBOOK
    for mode in ("full", "quick", "custom", None):
        monkeypatch.setenv("MUTUAL_OUTPUT_DIR", str(tmp_path / str(mode)))
        for var, value in ((ENV_MODE, mode), (ENV_NOTEBOOK, mode and str(tmp_path / "notebook.ipynb"))):
            if value:
                monkeypatch.setenv(var, value)
            else:
                monkeypatch.delenv(var, raising=False)
        fig, ax = plt.subplots()
        ax.plot([0, 1, 4])
        paths = savefig(fig, "fig_9_2")
        plt.close(fig)
        written = sorted(p.name for p in (tmp_path / str(mode)).iterdir())
        assert written == (["fig_9_2.png"] if mode == "quick" else ["fig_9_2.pdf", "fig_9_2.png"]), mode
        assert sorted(p.name for p in paths) == written
    assert (tmp_path / "quick" / "fig_9_2.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
