"""The command line's promises (issues 22 and 23): outputs written as a set, caches that cannot run code
and heal, bounded work with errors that name the option, and statistics commands that never import JAX."""

import ast
import errno
import json
import subprocess
import sys
import tracemalloc
import warnings
from pathlib import Path

import pandas as pd
import pytest

import mutual
from mutual.cli import common, main
from mutual.cache import CacheWarning
from mutual.study import sweep

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "data" / "examples" / "study.csv"
ANOVA = ["study", "anova", str(STUDY), "--dv", "value", "--within", "treatment", "--subject", "participant",
         "--where", "measure=false_positives", "--aggregate", "mean", "--no-progress"]
WRITTEN = {"anova_value_false_positives.csv", "pairwise_value_false_positives.csv", "cells_value_false_positives.csv",
           "means_value_false_positives.png"}


def _error(capsys):
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


# ---- outputs written as a set ----------------------------------------------------------------------

@pytest.mark.parametrize("fresh", [True, False])
def test_a_run_leaves_all_its_outputs(fresh, tmp_path, capsys):
    out = tmp_path / ("new" if fresh else "old")
    if not fresh:
        out.mkdir()
        (out / "mine.txt").write_text("kept")
        (out / "anova_value_false_positives.csv").write_text("stale")
    assert main(ANOVA + ["--out", str(out)]) == 0
    assert {p.name for p in out.iterdir()} == WRITTEN | (set() if fresh else {"mine.txt"})
    assert (out / "anova_value_false_positives.csv").read_text() != "stale"
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


# ---- caches that cannot run code -----------------------------------------------------------------------

def _task(t):
    return pd.DataFrame({"t": [t, t + 1], "x": [t / 3, float("nan")], "ok": [True, False], "who": [f"p{t}", None]})


def _sweep(cache, n=4):
    return sweep.run_tasks(_task, range(n), params=lambda t: {"t": t}, cache=cache, scheduler="inline", progress=False)


def test_nothing_in_the_package_unpickles():
    banned = {"pickle", "cPickle", "dill", "cloudpickle", "joblib", "shelve", "marshal"}
    for path in Path(mutual.__file__).parent.rglob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = {a.name.split(".")[0] for a in node.names} | {(getattr(node, "module", "") or "").split(".")[0]}
                assert not names & banned, f"{path} imports {names & banned}"
            if isinstance(node, ast.keyword) and node.arg == "allow_pickle":
                assert isinstance(node.value, ast.Constant) and node.value.value is False, path
            if isinstance(node, ast.Attribute) and node.attr in ("read_pickle", "to_pickle"):
                pytest.fail(f"{path} uses {node.attr}")


def test_a_planted_pickle_is_never_loaded(tmp_path):
    marker = tmp_path / "ran"
    cache = sweep.TaskCache("v", tmp_path / "cache")
    cache.folder.mkdir()
    planted = f"cos\nsystem\n(S'touch {marker}'\ntR.".encode()
    for t in range(4):
        (cache.folder / f"{cache.key({'t': t})}.pkl").write_bytes(planted)
        cache.path({"t": t}).write_bytes(planted)          # the same bytes where a result should be
    with pytest.warns(CacheWarning, match="does not verify"):
        results, stats = _sweep(cache)
    assert not marker.exists() and stats.computed == 4
    assert _sweep(cache)[1].cached == 4                    # healed: the planted files were replaced


FORGED = {  # how a stored result is changed: each must be refused and recomputed
    "a value of another type": lambda d: d["data"][0].__setitem__(0, "1"),
    "an object in a text column": lambda d: d["data"][3].__setitem__(0, {"__class__": "os.system"}),
    "a bool where a number belongs": lambda d: d["data"][1].__setitem__(0, True),
    "another task's key": lambda d: d.__setitem__("key", "0" * 32),
    "an unknown column type": lambda d: d["dtypes"].__setitem__(0, "category"),
    "columns of different lengths": lambda d: d["data"][0].append(3),
    "another format": lambda d: d.__setitem__("format", 99),
    "not an object": lambda d: d.clear(),
}


@pytest.mark.parametrize("forge", FORGED, ids=list(FORGED))
def test_a_forged_entry_is_healed(forge, tmp_path):
    cache = sweep.TaskCache("v", tmp_path)
    truth, _ = _sweep(cache, 1)
    path = cache.path({"t": 0})
    stored = json.loads(path.read_text())
    FORGED[forge](stored)
    path.write_text(json.dumps(stored))
    with pytest.warns(CacheWarning, match="does not verify"):
        again, stats = _sweep(cache, 1)
    assert stats.computed == 1
    pd.testing.assert_frame_equal(again[0], truth[0])
    assert _sweep(cache, 1)[1].cached == 1


def test_results_read_back_exactly(tmp_path):
    cache = sweep.TaskCache("v", tmp_path)
    first, _ = _sweep(cache)
    second, stats = _sweep(cache)
    assert stats.cached == 4
    for a, b in zip(first, second):
        pd.testing.assert_frame_equal(a, b)


def test_a_folder_where_a_result_should_be_heals(tmp_path):
    cache = sweep.TaskCache("v", tmp_path / "cache")
    cache.path({"t": 0}).mkdir(parents=True)
    (cache.path({"t": 0}) / "inside").write_text("x")
    results, stats = _sweep(cache)
    assert stats.computed == 4 and not cache.disabled and cache.path({"t": 0}).is_file()
    assert _sweep(cache)[1].cached == 4


@pytest.mark.parametrize("broken", ["the cache folder is a file", "no home folder"])
def test_a_cache_that_cannot_be_used_is_turned_off_with_one_warning(broken, tmp_path, monkeypatch):
    (tmp_path / "file").write_text("x")
    if broken == "no home folder":
        monkeypatch.delenv("MUTUAL_CACHE_DIR", raising=False)
        monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "file" / "cache"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cache = sweep.TaskCache("v", tmp_path / "file" / "power" if broken.startswith("the cache") else None)
        results, stats = _sweep(cache)
    assert stats.computed == 4 and len(results) == 4 and cache.disabled
    assert len([w for w in caught if issubclass(w.category, CacheWarning)]) == 1


# ---- bounded work, errors that name the option -------------------------------------------------------

def test_a_100000_character_level_name_is_cut_in_the_figure(tmp_path, capsys):
    name = "x" * 100_000
    rows = [f"s{i},{lv},{(i * i * 1.7 + j * i) % 5}" for i in range(4) for j, lv in enumerate((name, "b"))]
    (tmp_path / "d.csv").write_text("s,l,y\n" + "\n".join(rows) + "\n")
    assert main(["study", "anova", str(tmp_path / "d.csv"), "--dv", "y", "--within", "l", "--subject", "s",
                 "--out", str(tmp_path / "o")]) == 0
    from PIL import Image
    assert Image.open(tmp_path / "o" / "means_y.png").size[0] < 2000      # 87 s and a huge figure before
    assert max(len(line) for line in capsys.readouterr().out.splitlines()) < 1000     # the name is cut


def test_a_huge_range_of_sizes_is_refused_before_it_is_listed():
    from mutual.cli.power import parse_sizes
    tracemalloc.start()
    with pytest.raises(ValueError, match=r"--n 3:100000000: 99,999,998 sample sizes .* GB"):
        parse_sizes(["3:100000000"])
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 1_000_000


CLI_REFUSED = [  # (argv after `mutual study power`, phrases); exit status 2 with one line naming the option
    (["--n", "3:100000000"], ["--n", "GB"]),
    (["--n", "1001", "--quick", "--inline"], ["--n", "1,001", "CPU time"]),
    (["--cohorts", "1000000"], ["--cohorts", "days", "GB"]),
    (["--seed", "-1"], ["--seed", ">= 0"]),
    (["--seed", "nan"], ["--seed", "not a whole number"]),
    (["--seed", "1.5"], ["--seed", "not a whole number"]),
    (["--cohorts", "0"], ["--cohorts"]),
    (["--workers", "0"], ["--workers"]),
    (["--noise", "nan"], ["--noise", "finite"]),
    (["--alpha", "1.5"], ["--alpha"]),
    (["--f", "0.25", "--rho", "-0.6"], ["--rho -0.6", "-1/(m-1)"]),
    (["--f", "0.25", "--rho", "1"], ["--rho"]),
    (["--f", "0.25", "--eps", "0.4"], ["--eps 0.4", "[0.5, 1]"]),
    (["--f", "0.25", "--power", "0.04"], ["--power 0.04", "--alpha"]),
    (["--f", "1e300"], ["f must be at most"]),
    (["--f", "0.25", "--cohorts", "5"], ["--cohorts", "simulation option"]),
    (["--f", "0.25", "--from-f", "8", "2", "20"], ["--f and --from-f"]),
    (["--analytic-only", "--from-f", "8", "1e300", "20"], ["--from-f", "levels"]),
    (["--analytic-only", "--from-f", "1e300", "2", "20"], ["1e+300", "nothing to plan"]),
    (["--analytic-only", "--from-f", "8", "2.5", "20"], ["--from-f", "whole numbers"]),
    (["--analytic-only", "--rho", "0.2"], ["--rho goes with --f"]),
    (["--analytic-only", "--m", "4"], ["--m 4", "3 levels"]),
]


@pytest.mark.parametrize("argv, phrases", CLI_REFUSED, ids=[" ".join(c[0]) for c in CLI_REFUSED])
def test_power_options_are_refused_by_name(argv, phrases, tmp_path, capsys):
    try:
        status = main(["study", "power", *argv, "--out", str(tmp_path / "o"), "--no-progress"])
    except SystemExit as stop:            # argparse's own refusal (usage, then one error line)
        status = stop.code
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert status == 2 and "Traceback" not in err and all(p in err for p in phrases), err
    assert not (tmp_path / "o").exists()


def test_zero_effect_prints_not_reached(tmp_path, capsys):
    assert main(["study", "power", "--analytic-only", "--from-f", "0.5", "2", "20", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    sizes = [line.split()[-2:] for line in out.splitlines() if line.rstrip().endswith(("reached", "0", "6"))]
    assert ["not", "reached"] in sizes and ["66", "86"] in sizes
    assert "nan" not in out.lower() and "66.000" not in out
    assert main(["study", "power", "--f", "0", "--json", "--out", str(tmp_path)]) == 0
    rows = json.loads(capsys.readouterr().out)["gpower"]["rows"]
    assert [r["n"] for r in rows] == [None, None]


def test_the_help_states_measured_times_and_has_no_stray_markup(capsys):
    for argv in (["study", "anova", "--help"], ["study", "power", "--help"]):
        with pytest.raises(SystemExit):
            main(argv)
        text = capsys.readouterr().out
        assert "Measured" in text and "::" not in text and "well under a second" not in text


# ---- commands that answer at once: no JAX for statistics ----------------------------------------------

HEAVY = ("jax", "jaxlib", "hj_reachability", "cvxpy", "mutual.supervision", "mutual.motion", "mutual.constraints",
         "dask", "distributed")
PATHS = {
    "mutual --help": "from mutual.cli import build_parser; build_parser()",
    "import mutual.study": "import mutual.study, mutual.study.stats, mutual.study.power, mutual.study.data",
    "mutual study anova": f"from mutual.cli import main; assert main({ANOVA + ['--json', '--out', 'OUT']!r}) == 0",
    "mutual study power --analytic-only": "from mutual.cli import main; "
                                          "assert main(['study', 'power', '--analytic-only', '--out', 'OUT']) == 0",
    "mutual study power --f": "from mutual.cli import main; assert main(['study', 'power', '--f', '0.25', '--n', "
                              "'10', '--out', 'OUT']) == 0",
}


@pytest.mark.parametrize("path", PATHS, ids=list(PATHS))
def test_statistics_commands_never_import_jax(path, tmp_path):
    code = PATHS[path].replace("'OUT'", repr(str(tmp_path / "out"))) + (
        f"\nimport sys; print(sorted(m for m in {HEAVY!r} if m in sys.modules))")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.strip().splitlines()[-1] == "[]", run.stdout[-500:]
