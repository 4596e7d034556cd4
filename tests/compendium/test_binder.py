"""Binder-style launch files (binder/): they parse, they install the lock and register the kernel the
notebooks ask for, and (opt-in, slow) the same steps work in a clean virtual environment."""

import json
import os
import re
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest
from helpers.locks import canonical, pins

ROOT = Path(__file__).resolve().parents[2]
BINDER = ROOT / "binder"


def test_runtime_is_the_python_of_the_lock():
    runtime = (BINDER / "runtime.txt").read_text().strip()
    assert re.fullmatch(r"python-3\.\d+", runtime), runtime
    version = runtime.removeprefix("python-")
    assert f"Python {version}" in (ROOT / "environment.lock").read_text() or \
        f"python{version}" in (ROOT / "Makefile").read_text(), f"{runtime} is not the Python the lock is compiled for"
    assert f"PYTHON ?= python{version}" in (ROOT / "Makefile").read_text()


def test_requirements_install_exactly_the_lock():
    lines = [l.strip() for l in (BINDER / "requirements.txt").read_text().splitlines()
             if l.strip() and not l.strip().startswith("#")]
    assert lines == ["-r ../environment.lock"], lines
    assert (BINDER / "../environment.lock").resolve() == (ROOT / "environment.lock").resolve()
    pinned = pins(ROOT / "environment.lock")
    for needed in ("jupyterlab", "ipykernel", "ipywidgets", "papermill"):
        assert needed in pinned, f"the lock has no {needed}, which the Binder session needs"


def test_post_build_installs_mutual_and_registers_its_kernel():
    post = BINDER / "postBuild"
    assert post.stat().st_mode & stat.S_IXUSR, "binder/postBuild must be executable"
    text = post.read_text()
    assert text.startswith("#!/bin/bash\n") and "set -euo pipefail" in text
    subprocess.run(["bash", "-n", str(post)], check=True)
    assert "pip install --disable-pip-version-check --no-deps --no-build-isolation -e ." in text
    kernels = {json.loads(p.read_text())["metadata"]["kernelspec"]["name"] for p in (ROOT / "notebooks").glob("*.ipynb")}
    assert kernels == {"mutual"}, kernels
    assert '--sys-prefix --name mutual --display-name "Python (mutual)"' in text
    # the same steps as `make env`
    makefile = (ROOT / "Makefile").read_text()
    assert "ipykernel install --sys-prefix --name mutual --display-name \"Python (mutual)\"" in makefile
    assert "--no-deps --no-build-isolation -e ." in makefile


def test_post_build_is_committed_executable():
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    mode = subprocess.run(["git", "ls-files", "-s", "binder/postBuild"], cwd=ROOT, capture_output=True, text=True).stdout
    if not mode:
        pytest.skip("binder/postBuild is not committed yet")
    assert mode.startswith("100755"), f"binder/postBuild is committed without its executable bit: {mode.strip()}"


@pytest.mark.skipif(os.environ.get("MUTUAL_BINDER_INSTALL") != "1",
                    reason="slow (installs the whole lock into a fresh venv, minutes): MUTUAL_BINDER_INSTALL=1 to run")
def test_binder_steps_in_a_clean_venv(tmp_path):
    """What repo2docker does, in a fresh venv: pip install -r binder/requirements.txt, then binder/postBuild
    from the repository's root; then `mutual` imports and the kernel "mutual" runs this venv's Python."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    env = {**os.environ, "PATH": f"{venv / 'bin'}:{os.environ['PATH']}", "VIRTUAL_ENV": str(venv)}
    env.pop("PYTHONPATH", None)
    subprocess.run(["python", "-m", "pip", "install", "--disable-pip-version-check", "-q", "-r",
                    str(BINDER / "requirements.txt")], cwd=ROOT, env=env, check=True)
    subprocess.run([str(BINDER / "postBuild")], cwd=ROOT, env=env, check=True)
    python = venv / "bin" / "python"
    where = subprocess.run([str(python), "-c", "import mutual, ipywidgets; print(mutual.__file__)"],
                           env=env, capture_output=True, text=True, check=True).stdout.strip()
    assert Path(where).resolve().is_relative_to(ROOT / "lib")
    specs = json.loads(subprocess.run([str(venv / "bin" / "jupyter"), "kernelspec", "list", "--json"], env=env,
                                      capture_output=True, text=True, check=True).stdout)["kernelspecs"]
    assert "mutual" in specs and Path(specs["mutual"]["resource_dir"]).is_relative_to(venv)
    argv0 = json.loads((Path(specs["mutual"]["resource_dir"]) / "kernel.json").read_text())["argv"][0]
    assert Path(argv0).parent.resolve() == (venv / "bin").resolve() or argv0 == "python", argv0
    pinned = pins(ROOT / "environment.lock")
    frozen = subprocess.run([str(python), "-m", "pip", "freeze", "--all"], env=env, capture_output=True, text=True,
                            check=True).stdout
    installed = {canonical(k): v for k, v in (l.split("==", 1) for l in frozen.splitlines() if "==" in l)}
    wrong = {n: (v, installed.get(canonical(n))) for n, v in pinned.items() if installed.get(canonical(n)) != v}
    assert not wrong, f"the Binder venv differs from the lock: {dict(list(wrong.items())[:5])}"
