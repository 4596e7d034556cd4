"""Outputs written as a set (``mutual.cli.common.OutputSet``): a run leaves all of them, a failure while
writing or in a figure leaves none, an ``--out`` that is a file is refused before any work, and every
command writes through the set."""

import errno
from pathlib import Path

import pytest

from mutual.cli import common, main


ROOT = Path(__file__).resolve().parents[2]
STUDY = ROOT / "data" / "examples" / "study.csv"


ANOVA = ["study", "anova", str(STUDY), "--dv", "value", "--within", "treatment", "--subject", "participant",
         "--where", "measure=false_positives", "--aggregate", "mean", "--no-progress"]


WRITTEN = {"anova_value+measure=false_positives.csv", "pairwise_value+measure=false_positives.csv", "cells_value+measure=false_positives.csv",
           "means_value+measure=false_positives.png"}


def _error(capsys):
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("fresh", [True, False])
def test_a_run_leaves_all_its_outputs(fresh, tmp_path, capsys):
    out = tmp_path / ("new" if fresh else "old")
    if not fresh:
        out.mkdir()
        (out / "mine.txt").write_text("kept")
        (out / "anova_value+measure=false_positives.csv").write_text("stale")
    assert main(ANOVA + ["--out", str(out)]) == 0
    assert {p.name for p in out.iterdir()} == WRITTEN | (set() if fresh else {"mine.txt"})
    assert (out / "anova_value+measure=false_positives.csv").read_text() != "stale"
    assert out.stat().st_mode & 0o755 == 0o755          # readable by others, as a folder mkdir makes
    assert not [p for p in tmp_path.rglob(".*")], "a temporary folder was left"


@pytest.mark.parametrize("fresh", [True, False])
def test_a_failure_while_writing_leaves_none(fresh, tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    if not fresh:
        out.mkdir()
    calls = []

    def full_disk(self, fig, name):          # the fourth file of four hits a full disk
        import matplotlib.pyplot as plt
        plt.close(fig)
        calls.append(name)
        raise OSError(errno.ENOSPC, "No space left on device", str(self.path(name)))
    monkeypatch.setattr(common.OutputSet, "figure", full_disk)
    assert main(ANOVA + ["--out", str(out)]) == 1
    err = _error(capsys)
    assert "No space left on device" in err and "no output was left" in err and "--out" in err
    assert calls and (not out.exists() if fresh else not list(out.iterdir()))
    assert not [p for p in tmp_path.rglob(".*")]


def test_an_error_in_a_figure_leaves_no_output(tmp_path, capsys, monkeypatch):
    from mutual.cli import study
    monkeypatch.setattr(study, "_figure", lambda *a: (_ for _ in ()).throw(RuntimeError("no figure")))
    assert main(ANOVA + ["--out", str(tmp_path / "out")]) == 1
    assert "no figure" in _error(capsys) and not (tmp_path / "out").exists()


def test_out_that_is_a_file_is_refused_before_any_work(tmp_path, capsys, monkeypatch):
    (tmp_path / "f").write_text("x")
    from mutual.cli import study
    monkeypatch.setattr(study, "analyse", lambda *a: pytest.fail("the work started"))
    assert main(ANOVA + ["--out", str(tmp_path / "f")]) == 2
    assert "exists and is not a folder" in _error(capsys)


def test_every_command_writes_through_the_output_set():
    """One mechanism: no command module writes files itself (common.output_set does)."""
    for name in ("constraints", "continuous", "motion", "power", "study", "supervisor"):
        source = (Path(common.__file__).parent / f"{name}.py").read_text()
        assert "output_set(args)" in source, name
        assert "write_csv(" not in source and "save_figure(" not in source and "to_csv(" not in source, name


@pytest.mark.parametrize("category, one_line", [("InputWarning", True), ("CacheWarning", True),
                                                ("RuntimeWarning", False)])
def test_input_and_cache_warnings_are_one_line_naming_the_command(capsys, category, one_line):
    from mutual.cache import CacheWarning
    from mutual.inputs import InputWarning
    kind = {"InputWarning": InputWarning, "CacheWarning": CacheWarning, "RuntimeWarning": RuntimeWarning}[category]
    common._show_warning("mutual x")("the cache in /c cannot be used", kind, "file.py", 7, line="source line")
    err = capsys.readouterr().err
    assert (err == "mutual x: warning: the cache in /c cannot be used\n") == one_line, err
