"""Faults of the runner and the report: a notebook that raises, a killed kernel, SIGTERM during a run, a kernel
that will not stop, a missing notebook, stale and quick results, two report builds at once, disk errors.
Each asserts what the user sees (one line naming the notebook and the cell, no traceback) and that no file
is left half-written."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import nbformat
import pytest

import mutual.compendium.paths as paths
import mutual.compendium.runs as runs
from mutual.compendium.report import build_report, main as report_main
from mutual.compendium.results import write_extensions, write_results

WRITE_AND_WAIT = """import os, time
from mutual.atomic import atomic_path
from mutual.compendium.paths import figures_dir
(figures_dir() / "kernel.pid").write_text(str(os.getpid()))
with atomic_path(figures_dir() / "fig_9_9.png") as tmp:
    tmp.write_text("half")
    {wait}"""
PATIENT = "time.sleep(120)"
STUBBORN = """for _ in range(1200):
        try:
            time.sleep(0.1)
        except KeyboardInterrupt:
            pass"""


def _notebook(folder, name, *sources):
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "mutual", "display_name": "Python (mutual)", "language": "python"}
    nb.cells = [nbformat.v4.new_code_cell(s) for s in ("quick = False",) + sources]
    nb.cells[0].metadata["tags"] = ["parameters"]
    path = Path(folder) / f"{name}.ipynb"
    nbformat.write(nb, path)
    return path


@pytest.fixture
def out(tmp_path):
    """An output folder holding a good figure and the previous results of ``99_fault``."""
    folder = tmp_path / "out"
    (folder / "results" / "extensions").mkdir(parents=True)
    (folder / "fig_9_9.png").write_text("the good figure")
    for sub in ("results", "results/extensions"):
        (folder / sub / "99_fault.json").write_text('{"notebook": "99_fault", "claims": {}}')
    return folder


def _runner(notebook, out, *args):
    env = {**os.environ, "MUTUAL_OUTPUT_DIR": str(out)}
    return subprocess.Popen([sys.executable, "-m", "mutual.compendium.notebooks", *args, str(notebook)],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _leftovers(folder):
    return sorted(p.name for p in Path(folder).rglob(".*") if p.is_file())


def _wait_for(condition, seconds=60):
    end = time.time() + seconds
    while time.time() < end:
        if condition():
            return True
        time.sleep(0.1)
    return False


def _gone(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


def _one_line(stderr):
    lines = [ln for ln in stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in stderr, f"expected one line, got:\n{stderr}"
    return lines[0]


def test_a_notebook_that_raises_leaves_no_results(tmp_path, out):
    path = _notebook(tmp_path, "99_fault", "x = 1", "raise RuntimeError('boom')")
    proc = _runner(path, out)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 1
    line = _one_line(stderr)
    assert "99_fault.ipynb failed in code cell 3 (\"raise RuntimeError('boom')\"): RuntimeError: boom" in line
    assert not (out / "results" / "99_fault.json").exists(), "stale results of the failed notebook remain"
    assert not (out / "results" / "extensions" / "99_fault.json").exists()
    assert (out / "fig_9_9.png").read_text() == "the good figure"
    executed = nbformat.read(out / "executed" / "99_fault.ipynb", as_version=4)
    assert executed.cells[2].outputs[0]["ename"] == "RuntimeError"  # the traceback is kept there


def test_results_written_before_a_failure_are_removed(tmp_path, out):
    path = _notebook(tmp_path, "99_fault", "from mutual.compendium.results import write_extensions\n"
                     "write_extensions('99_fault', {'k': {'statement': 's', 'value': 1, "
                     "'computed_by': 'mutual.study.stats.rm_anova'}})", "1 / 0")
    proc = _runner(path, out)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 1 and "ZeroDivisionError" in _one_line(stderr)
    assert not (out / "results" / "extensions" / "99_fault.json").exists()


def test_a_killed_kernel_is_named(tmp_path, out):
    path = _notebook(tmp_path, "99_fault", "import os, signal\nos.kill(os.getpid(), signal.SIGKILL)")
    proc = _runner(path, out)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 1
    line = _one_line(stderr)
    assert "notebook 99_fault.ipynb, code cell 2 ('import os, signal'): the kernel died (killed by SIGKILL" in line
    assert not (out / "results" / "99_fault.json").exists()
    assert _leftovers(out) == []


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_signal_stops_the_run_cleanly(tmp_path, out, signum):
    """The running cell is interrupted, so its atomic write cleans up; the kernel is shut down."""
    path = _notebook(tmp_path, "99_fault", WRITE_AND_WAIT.format(wait=PATIENT))
    proc = _runner(path, out)
    assert _wait_for(lambda: any(p.name.startswith(".fig_9_9") for p in out.iterdir())), proc.communicate()
    proc.send_signal(signum)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signum
    line = _one_line(stderr)
    name = signal.Signals(signum).name
    assert f"stopped by {name} in notebook 99_fault.ipynb, code cell 2 ('import os, time'); it left no results" in line
    assert "temporary" not in line  # the interrupted cell removed its own temporary file
    assert _leftovers(out) == [], "temporary files left behind"
    assert (out / "fig_9_9.png").read_text() == "the good figure", "the previous figure was lost or half-written"
    assert not (out / "results" / "99_fault.json").exists()
    assert _wait_for(lambda: _gone(int((out / "kernel.pid").read_text())), 10), "the kernel is still running"


def test_a_second_signal_kills_a_kernel_that_will_not_stop(tmp_path, out):
    """A cell that swallows KeyboardInterrupt: the second SIGTERM kills the kernel, and the runner removes
    the temporary file it left."""
    path = _notebook(tmp_path, "99_fault", WRITE_AND_WAIT.format(wait=STUBBORN))
    proc = _runner(path, out)
    assert _wait_for(lambda: any(p.name.startswith(".fig_9_9") for p in out.iterdir())), proc.communicate()
    proc.send_signal(signal.SIGTERM)
    time.sleep(1.0)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signal.SIGTERM
    assert "stopped by SIGTERM in notebook 99_fault.ipynb, code cell 2" in _one_line(stderr)
    assert "removed 1 temporary file(s) the kernel left" in stderr
    assert _leftovers(out) == [] and (out / "fig_9_9.png").read_text() == "the good figure"
    assert _wait_for(lambda: _gone(int((out / "kernel.pid").read_text())), 10), "the kernel is still running"


def test_a_missing_notebook_is_one_line(tmp_path, out):
    proc = _runner(tmp_path / "99_nope.ipynb", out)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 1 and "no notebook at" in _one_line(stderr) and "99_nope.ipynb" in stderr


# -- the report: stale results, quick results, concurrent builds ---------------------------------------

@pytest.fixture
def ran(tmp_path, monkeypatch):
    """Results of ``09_demo`` written in-process as a full run of a notebook in ``tmp_path``."""
    monkeypatch.setenv("MUTUAL_OUTPUT_DIR", str(tmp_path / "figures"))
    notebook = _notebook(tmp_path, "09_demo", "x = 1")

    def write(mode="full"):
        for key, value in runs.kernel_env(notebook, {} if mode == "full" else {"quick": True}).items():
            monkeypatch.setenv(key, value)
        write_results("09_demo", {"c2-thm231-recursion": {"value": True, "note": "n", "computed_by":
                                                          "mutual.study.stats.rm_anova"}})
        write_extensions("09_demo", {"k": {"statement": "s", "value": 1, "computed_by": "mutual.study.stats.rm_anova"}})
        return notebook

    return write


def test_the_report_refuses_results_older_than_their_notebook(ran, capsys):
    notebook = ran()
    assert "| c2-thm231-recursion |" in build_report().read_text()
    nb = nbformat.read(notebook, as_version=4)
    nb.cells[1].source = "x = 2"
    nbformat.write(nb, notebook)
    with pytest.raises(SystemExit) as exit_:
        report_main([])
    assert exit_.value.code != 0
    assert "results/09_demo.json: older than its notebook" in str(exit_.value.code)
    assert "09_demo.ipynb (its code changed after the run)" in str(exit_.value.code)
    notebook.unlink()
    with pytest.raises(ValueError, match="09_demo.ipynb no longer exists"):
        build_report()


def test_the_report_refuses_results_without_a_run_record(ran):
    ran()
    path = Path(os.environ["MUTUAL_OUTPUT_DIR"]) / "results" / "09_demo.json"
    doc = json.loads(path.read_text())
    del doc["run"]
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="results/09_demo.json: written before runs were recorded"):
        build_report()


def test_the_committed_report_refuses_quick_results(ran, monkeypatch, tmp_path):
    ran(mode="quick")
    text = build_report().read_text()  # a scratch report: allowed, and says so
    assert "**Not the committed report**" in text and "09_demo (quick)" in text
    monkeypatch.setattr(paths, "FIGURES", tmp_path / "figures")  # now the output folder is "committed"
    with pytest.raises(ValueError, match="written by a quick run of .*09_demo.ipynb; the committed report takes full"):
        build_report()
    ran(mode="full")
    assert "Not the committed report" not in build_report().read_text()


def test_two_report_builds_at_once(tmp_path, monkeypatch):
    """Two builds into one folder at once: each finishes, and the report is whole (atomic replace)."""
    out = tmp_path / "figures"
    monkeypatch.setenv("MUTUAL_OUTPUT_DIR", str(out))
    reference = build_report().read_text()
    command = [sys.executable, "-m", "mutual.compendium.report"]
    procs = [subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)]
    for proc in procs:
        _, stderr = proc.communicate(timeout=120)
        assert proc.returncode == 0, stderr
    assert (out / "REPRODUCTION.md").read_text() == reference
    assert _leftovers(out) == []


# -- two runners on one output folder, and disk errors in one line ---------------------------------

WAIT_FOR_RELEASE = """import time
from mutual.compendium.paths import figures_dir
(figures_dir() / "started").write_text("yes")
for _ in range(600):
    if (figures_dir() / "release").exists():
        break
    time.sleep(0.1)"""


def test_a_second_runner_on_the_same_folder_stops_naming_the_first(tmp_path, out):
    first = _runner(_notebook(tmp_path, "99_first", WAIT_FOR_RELEASE), out)
    assert _wait_for(lambda: (out / "started").exists()), first.communicate()
    second = _runner(_notebook(tmp_path, "99_second", "x = 1"), out, "-p", "quick=True")
    _, stderr = second.communicate(timeout=120)
    assert second.returncode == 1
    line = _one_line(stderr)
    assert f"another runner is writing to {out}" in line and f"pid {first.pid}" in line and "99_first.ipynb" in line
    elsewhere = _runner(_notebook(tmp_path, "99_third", "x = 1"), tmp_path / "elsewhere")
    assert elsewhere.communicate(timeout=120) and elsewhere.returncode == 0, "another folder is not locked"
    (out / "release").write_text("go")
    _, stderr = first.communicate(timeout=120)
    assert first.returncode == 0, stderr
    assert not (out / "results" / "99_second.json").exists() and not (out / "executed" / "99_second.ipynb").exists()
    assert not (out / "executed" / "running.json").exists()
    again = _runner(_notebook(tmp_path, "99_second", "x = 1"), out)
    assert again.communicate(timeout=120) and again.returncode == 0, "the lock outlived its runner"


def test_a_killed_runner_releases_the_folder(tmp_path, out):
    first = _runner(_notebook(tmp_path, "99_first", WAIT_FOR_RELEASE), out)
    assert _wait_for(lambda: (out / "started").exists()), first.communicate()
    first.kill()
    first.communicate(timeout=60)
    (out / "release").write_text("go")   # lets the orphaned kernel finish
    again = _runner(_notebook(tmp_path, "99_second", "x = 1"), out)
    _, stderr = again.communicate(timeout=120)
    assert again.returncode == 0, stderr


def test_the_lock_is_held_within_one_process(tmp_path, monkeypatch):
    """execute() inside main()'s lock does not lock itself out; a second holder in the process is told."""
    import fcntl
    from mutual.compendium.lock import OutputBusy, output_lock
    folder = tmp_path / "o"
    folder.mkdir()
    with output_lock(folder, tmp_path / "info.json", "quick", ["a.ipynb"], {"quick": True}):
        with output_lock(folder, tmp_path / "info.json", "quick", ["a.ipynb"], {"quick": True}):
            pass
        other = os.open(folder, os.O_RDONLY)
        with pytest.raises(BlockingIOError):
            fcntl.flock(other, fcntl.LOCK_EX | fcntl.LOCK_NB)
        os.close(other)
    with output_lock(folder, tmp_path / "info.json", "quick", ["a.ipynb"], {}):
        pass
    assert OutputBusy.__doc__


def test_output_that_is_a_file_is_one_line(tmp_path):
    target = tmp_path / "figures.png"
    target.write_text("not a folder")
    proc = _runner(_notebook(tmp_path, "99_fault", "x = 1"), target)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 1
    assert f"cannot write {target}: it is a file, not a folder" in _one_line(stderr)
    assert target.read_text() == "not a folder"


def _in_a_tmpfs(tmp_path, options, args, notebook, prepare=""):
    """The runner with ``--output`` on a tmpfs mounted with ``options`` in a private mount namespace."""
    import shutil
    if shutil.which("unshare") is None:
        pytest.skip("needs unshare(1)")
    mnt = tmp_path / "mnt"
    mnt.mkdir(exist_ok=True)
    command = " ".join([sys.executable, "-m", "mutual.compendium.notebooks", *args, "--output", str(mnt / "out"),
                        str(notebook)])
    script = f"mount -t tmpfs -o {options} tmpfs {mnt} && {prepare.format(mnt=mnt)} exec {command}"
    env = {k: v for k, v in os.environ.items() if k != "MUTUAL_OUTPUT_DIR"}
    proc = subprocess.run(["unshare", "-m", "--propagation", "private", "sh", "-c", script], capture_output=True,
                          text=True, env=env, timeout=300)
    if "mount:" in proc.stderr or "unshare:" in proc.stderr:
        pytest.skip(f"mounting a tmpfs is not allowed here: {proc.stderr.strip()[:200]}")
    return proc


FILL_THE_DISK = """from mutual.compendium.paths import figures_dir
with open(figures_dir() / "big.bin", "wb") as handle:
    handle.write(b"x" * 10_000_000)"""

DISKS = [  # (what, mount options, shell preparation, notebook cell, expected in the one line)
    ("a read-only output folder", "ro,size=64k", "", "x = 1", "Read-only file system (EROFS)"),
    ("a read-only output folder made before", "size=64k", "mkdir -p {mnt}/out && mount -o remount,ro {mnt} &&",
     "x = 1", "Read-only file system (EROFS)"),
    ("a full disk in a cell", "size=256k", "", FILL_THE_DISK,
     "99_fault.ipynb failed in code cell 2 ('from mutual.compendium.paths import figures_dir'): OSError: "
     "[Errno 28] No space left on device"),
    ("a disk full before the run", "size=4k", "mkdir -p {mnt}/out/executed && head -c 4096 /dev/zero > {mnt}/fill;",
     "x = 1", "No space left on device (ENOSPC)"),
]


@pytest.mark.parametrize("what, options, prepare, cell, expected", DISKS, ids=[d[0] for d in DISKS])
def test_disk_errors_are_one_line_naming_the_cause(tmp_path, what, options, prepare, cell, expected):
    proc = _in_a_tmpfs(tmp_path, options, [], _notebook(tmp_path, "99_fault", cell), prepare)
    assert proc.returncode == 1, proc.stderr
    line = _one_line(proc.stderr)
    assert expected in line and line.startswith("notebook runner: "), line


def test_a_full_disk_for_the_executed_copy_keeps_the_cells_error(tmp_path, monkeypatch):
    """The executed copy cannot be saved after a cell failed: the line names the cell and both causes."""
    import errno
    from mutual.compendium import notebooks
    monkeypatch.setenv("MUTUAL_OUTPUT_DIR", str(tmp_path / "out"))

    def full(target, text):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(target))

    monkeypatch.setattr(notebooks, "write_text", full)
    with pytest.raises(notebooks.NotebookError) as err:
        notebooks.execute(_notebook(tmp_path, "99_fault", "1 / 0"), {"quick": True})
    message = str(err.value)
    assert "failed in code cell 2 ('1 / 0'): ZeroDivisionError" in message and "\n" not in message
    assert "its executed copy was not saved (cannot write" in message and "No space left on device (ENOSPC)" in message
    with pytest.raises(notebooks.NotebookError, match="ran, but its executed copy was not saved"):
        notebooks.execute(_notebook(tmp_path, "99_fine", "x = 1"), {"quick": True})
