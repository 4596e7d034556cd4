"""A lab that is safe to play in: only `make figures` writes the committed outputs, quick and custom runs go
to the scratch folder, notebook outputs never reach a commit, and `make lab` starts (as root too) on the
overview with the `mutual` kernel."""

import json
import os
import queue
import shutil
import signal
import subprocess
import sys
import threading
import time
import urllib.request

import nbformat
import pytest
from helpers.servers import free_port, wait_for_http

import mutual.compendium.paths as paths
from mutual.compendium.hygiene import dirty_cells, strip_before_save, stripped_text

NOTEBOOK_PATHS = sorted(paths.NOTEBOOKS.glob("[0-9][0-9]_*.ipynb"))


def _lab_autosave(nb):
    """What JupyterLab does to a notebook it ran and saved: outputs, counts, kernel details, widget state."""
    for i, cell in enumerate(c for c in nb.cells if c.cell_type == "code"):
        cell.execution_count = i + 1
        cell.outputs = [nbformat.v4.new_output("stream", name="stdout", text="42\n"),
                        nbformat.v4.new_output("display_data", data={"image/png": "iVBORw0KGgo=", "text/plain": "<Figure>"})]
        cell.metadata["scrolled"] = True
        cell.metadata["execution"] = {"iopub.status.idle": "2026-01-01T00:00:00Z"}
    nb.metadata["language_info"] = {"codemirror_mode": {"name": "ipython", "version": 3}, "file_extension": ".py",
                                    "mimetype": "text/x-python", "name": "python", "nbconvert_exporter": "python",
                                    "pygments_lexer": "ipython3", "version": "3.11.7"}
    nb.metadata["widgets"] = {"application/vnd.jupyter.widget-state+json": {"state": {}, "version_major": 2}}
    return nb


def test_outputs_go_to_scratch_unless_make_figures_says_otherwise(monkeypatch):
    monkeypatch.delenv("MUTUAL_OUTPUT_DIR")
    assert paths.figures_dir() == paths.SCRATCH and paths.SCRATCH.is_relative_to(paths.BUILD)
    assert paths.generated_data_dir() == paths.SCRATCH / "data" and not paths.is_committed()
    assert paths.results_dir() == paths.SCRATCH / "results"
    monkeypatch.setenv("MUTUAL_OUTPUT_DIR", str(paths.ROOT / "figures"))
    assert paths.is_committed() and paths.generated_data_dir() == paths.DATA
    assert paths.executed_dir() == paths.BUILD / "executed"


def _committed_state():
    tracked = subprocess.run(["git", "-C", str(paths.ROOT), "status", "--porcelain", "--", "figures", "data"],
                             capture_output=True, text=True).stdout
    files = {p: p.stat().st_mtime_ns for d in (paths.FIGURES, paths.DATA) for p in d.rglob("*") if p.is_file()}
    return tracked, files


def test_a_quick_run_writes_the_scratch_folder_never_figures(tmp_path):
    name = f"99_scratch_{os.getpid()}"
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "mutual", "display_name": "Python (mutual)", "language": "python"}
    nb.cells = [nbformat.v4.new_code_cell("quick = False"), nbformat.v4.new_code_cell(
        "import pandas as pd\nfrom mutual.compendium.figures import save_table\n"
        "from mutual.compendium.paths import generated_data_dir\n"
        f"save_table(pd.DataFrame({{'a': [1]}}), 'table_99_scratch_{os.getpid()}')\n"
        f"generated_data_dir().mkdir(parents=True, exist_ok=True)\n"
        f"(generated_data_dir() / '{name}.csv').write_text('a\\n1\\n')")]
    nb.cells[0].metadata["tags"] = ["parameters"]
    nbformat.write(nb, tmp_path / f"{name}.ipynb")
    before = _committed_state()
    env = {k: v for k, v in os.environ.items() if k != "MUTUAL_OUTPUT_DIR"}
    made = [paths.SCRATCH / f"table_99_scratch_{os.getpid()}.csv", paths.SCRATCH / f"table_99_scratch_{os.getpid()}.md",
            paths.SCRATCH / "data" / f"{name}.csv", paths.SCRATCH / "executed" / f"{name}.ipynb",
            paths.SCRATCH / "executed" / f"{name}.kernel.log"]
    try:
        out = subprocess.run([sys.executable, "-m", "mutual.compendium.notebooks", "--quick", str(tmp_path / f"{name}.ipynb")],
                             env=env, capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, out.stderr
        assert "outputs to build/scratch" in out.stdout
        assert all(p.exists() for p in made), [p for p in made if not p.exists()]
        assert _committed_state() == before, "a quick run changed figures/ or data/"
    finally:
        for p in made:
            p.unlink(missing_ok=True)


@pytest.mark.parametrize("args", [["--quick", "--output", "figures"], ["-p", "seed=1", "--output", "figures"]],
                         ids=["quick", "custom"])
def test_the_runner_refuses_quick_or_custom_runs_into_figures(args):
    before = _committed_state()
    out = subprocess.run([sys.executable, "-m", "mutual.compendium.notebooks", *args,
                          str(paths.NOTEBOOKS / "00_overview.ipynb")], capture_output=True, text=True,
                         cwd=paths.ROOT, timeout=120)
    assert out.returncode != 0
    assert "never write the committed figures/" in out.stderr and "Traceback" not in out.stderr
    assert _committed_state() == before


@pytest.mark.parametrize("path", NOTEBOOK_PATHS, ids=[p.stem for p in NOTEBOOK_PATHS])
def test_the_lab_saves_notebooks_as_they_are_committed(path):
    """The pre-save hook of `make lab`: a notebook run and saved in the lab is byte-identical on disk."""
    committed = path.read_text()
    model = {"type": "notebook", "content": _lab_autosave(nbformat.reads(committed, as_version=4))}
    strip_before_save(model=model, path=f"notebooks/{path.name}", contents_manager=None)
    assert nbformat.writes(model["content"]) + "\n" == committed
    elsewhere = {"type": "notebook", "content": _lab_autosave(nbformat.reads(committed, as_version=4))}
    strip_before_save(model=elsewhere, path=f"build/{path.name}", contents_manager=None)
    assert dirty_cells(nbformat.writes(elsewhere["content"]))  # only notebooks/ is stripped


def test_outputs_never_reach_a_commit(tmp_path):
    """In a repository with this .gitattributes and the filter `make env` installs, a notebook the lab
    ran and autosaved with outputs diffs as unchanged and stages nothing."""
    if shutil.which("git") is None:
        pytest.skip("git is not installed")
    git = lambda *a: subprocess.run(["git", "-C", str(tmp_path), *a], capture_output=True, text=True)  # noqa: E731
    git("init", "-q")
    git("config", "user.email", "t@example.org")
    git("config", "user.name", "t")
    git("config", "filter.nbstripout.clean", f"'{sys.executable}' -m mutual.compendium.hygiene")
    git("config", "filter.nbstripout.smudge", "cat")
    shutil.copy(paths.ROOT / ".gitattributes", tmp_path / ".gitattributes")
    source = paths.NOTEBOOKS / "00_overview.ipynb"
    (tmp_path / "notebooks").mkdir()
    target = tmp_path / "notebooks" / source.name
    shutil.copy(source, target)
    git("add", "-A")
    git("commit", "-qm", "clean")
    nbformat.write(_lab_autosave(nbformat.read(target, as_version=4)), target)
    assert dirty_cells(target.read_text())  # the working copy has outputs, as after a lab session
    assert git("diff", "--quiet").returncode == 0, git("diff").stdout
    git("add", "-A")
    assert git("diff", "--cached", "--quiet").returncode == 0, "git add staged outputs"
    assert git("show", ":notebooks/00_overview.ipynb").stdout == source.read_text()
    assert stripped_text(target.read_text()) == source.read_text()


def _get(url, method="GET", body=None):
    request = urllib.request.Request(url, method=method, data=None if body is None else json.dumps(body).encode(),
                                     headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=30) as response:
        return json.loads(response.read() or b"null")


def test_make_lab_starts_on_the_overview_with_the_mutual_kernel(tmp_path):
    """`make lab` as this user (root included): the server starts, would open 00_overview.ipynb, offers the
    `mutual` kernel, and saves a notebook under notebooks/ without outputs."""
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    port, token = free_port(), "compendium-test"
    flags = f"--port={port} --IdentityProvider.token={token} --ServerApp.browser='/bin/echo OPEN %s'"
    env = {**os.environ, "JUPYTER_RUNTIME_DIR": str(tmp_path / "runtime")}
    proc = subprocess.Popen(["make", "--no-print-directory", "lab", f"LABFLAGS={flags}"], cwd=paths.ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    lines = queue.Queue()
    threading.Thread(target=lambda: [lines.put(line) for line in proc.stdout], daemon=True).start()
    log, opened = [], None
    scratch = f"notebooks/zz_lab_hygiene_{os.getpid()}.ipynb"
    try:
        end = time.time() + 120
        while opened is None and time.time() < end and proc.poll() is None:
            try:
                log.append(lines.get(timeout=1))
            except queue.Empty:
                continue
            if log[-1].startswith("OPEN "):
                opened = log[-1].split(" ", 1)[1].strip().removeprefix("file://")
        assert opened, "make lab did not start:\n" + "".join(log)
        html = open(opened).read()
        assert f"localhost:{port}/lab/tree/notebooks/00_overview.ipynb" in html, html
        base = f"http://127.0.0.1:{port}/api"
        wait_for_http(f"{base}/status?token={token}", proc, "make lab's JupyterLab")
        assert "mutual" in _get(f"{base}/kernelspecs?token={token}")["kernelspecs"]
        nb = _lab_autosave(nbformat.read(paths.NOTEBOOKS / "00_overview.ipynb", as_version=4))
        _get(f"{base}/contents/{scratch}?token={token}", "PUT", {"type": "notebook", "format": "json", "content": nb})
        saved = (paths.ROOT / scratch).read_text()
        assert not dirty_cells(saved), "the lab saved outputs into notebooks/"
        assert saved == (paths.NOTEBOOKS / "00_overview.ipynb").read_text()
    finally:
        (paths.ROOT / scratch).unlink(missing_ok=True)
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)


def test_a_run_into_scratch_that_writes_the_committed_data_fails(tmp_path, monkeypatch):
    """A notebook that bypasses generated_data_dir() and writes data/ directly is named, not silent."""
    from mutual.compendium.notebooks import NotebookError, execute

    committed = tmp_path / "data"
    committed.mkdir()
    monkeypatch.setattr(paths, "DATA", committed)
    monkeypatch.setattr(paths, "FIGURES", tmp_path / "figures")
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "mutual", "display_name": "Python (mutual)", "language": "python"}
    nb.cells = [nbformat.v4.new_code_cell("quick = False"),
                nbformat.v4.new_code_cell(f"open({str(committed / 'ch3_demonstrations.csv')!r}, 'w').write('x')")]
    nb.cells[0].metadata["tags"] = ["parameters"]
    nbformat.write(nb, tmp_path / "99_writer.ipynb")
    with pytest.raises(NotebookError, match=r"99_writer.ipynb wrote the committed .*data/ch3_demonstrations.csv in a "
                                            r"quick run .*write through figures_dir\(\) and generated_data_dir\(\)"):
        execute(tmp_path / "99_writer.ipynb", {"quick": True})
