"""`make env`'s install (Makefile, $(READY)): pip installs the pinned uv (installer.lock), uv installs the
hash-checked environment.lock (or pip, `INSTALLER=pip`); the environment the tests run in is that lock, package
for package."""

import shutil
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest
from helpers.locks import canonical, options, pins
from mutual.compendium.paths import ROOT

LOCKS = ("environment.lock", "installer.lock", "bench/peers/requirements.lock")


def test_the_installer_lock_pins_uv_alone_with_its_hashes():
    assert list(pins(ROOT / "installer.lock")) == ["uv"]
    assert [line.strip() for line in (ROOT / "installer.in").read_text().splitlines()
            if line.strip() and not line.startswith("#")] == [f"uv=={pins(ROOT / 'installer.lock')['uv']}"]


def _recipe(*settings):
    """The commands `make env` would run to install the environment (``make -n``, the lock taken as new)."""
    done = subprocess.run(["make", "-n", "--no-print-directory", "-W", "environment.lock", ".venv/.ready", *settings],
                          cwd=ROOT, capture_output=True, text=True)
    return done.returncode, done.stdout + done.stderr


@pytest.mark.skipif(shutil.which("make") is None, reason="needs make")
def test_make_installs_both_locks_hash_checked_with_uv_or_pip():
    code, uv = _recipe()
    assert code == 0 and "pip install --disable-pip-version-check --quiet --require-hashes --no-deps " \
        "-r installer.lock" in uv
    assert "uv pip install --python .venv/bin/python --compile-bytecode --require-hashes --no-deps " \
        "-r environment.lock" in uv
    code, pip = _recipe("INSTALLER=pip")
    assert code == 0 and "installer.lock" not in pip and "bin/uv" not in pip
    assert "python -m pip install --disable-pip-version-check --require-hashes --no-deps -r environment.lock" in pip
    code, other = _recipe("INSTALLER=conda")
    assert code != 0 and "INSTALLER must be uv or pip, not conda" in other


@pytest.mark.parametrize("lock", LOCKS)
def test_the_locks_name_no_folder_of_the_machine_that_compiled_them(lock):
    """pip-compile copies the compiling machine's pip settings (``--find-links /opt/wheels``); uv refuses a
    lock whose folder is missing on the machine that installs it ("relative URL without a base")."""
    assert options(ROOT / lock) == [], f"{lock} has machine-specific options; recompile it (`make lock`, `lock-peers`)"


@pytest.mark.skipif(Path(sys.prefix).resolve() != (ROOT / ".venv").resolve(),
                    reason="runs in the environment `make env` made (.venv)")
def test_the_environment_is_the_lock():
    installed = {canonical(d.metadata["Name"]): d.version for d in metadata.distributions()}
    wrong = {name: (version, installed.get(name)) for name, version in pins(ROOT / "environment.lock").items()
             if installed.get(name) != version}
    assert not wrong, f".venv differs from environment.lock (name: (lock, installed)): {dict(list(wrong.items())[:5])}"
