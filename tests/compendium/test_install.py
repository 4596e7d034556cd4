"""`make env`'s install (Makefile, $(READY)): pip installs the pinned uv (installer.lock), uv installs the
hash-checked environment.lock; the environment the tests run in is that lock, package for package."""

import sys
from importlib import metadata

import pytest
from helpers.locks import canonical, options, pins
from mutual.compendium.paths import ROOT

LOCKS = ("environment.lock", "installer.lock", "bench/peers/requirements.lock")


def test_the_installer_lock_pins_uv_alone_with_its_hashes():
    assert list(pins(ROOT / "installer.lock")) == ["uv"]
    assert [line.strip() for line in (ROOT / "installer.in").read_text().splitlines()
            if line.strip() and not line.startswith("#")] == [f"uv=={pins(ROOT / 'installer.lock')['uv']}"]


def test_make_installs_both_locks_hash_checked():
    recipe = (ROOT / "Makefile").read_text().split("$(READY): ", 1)[1].split("\n\n", 1)[0]
    assert "pip install" in recipe and "--require-hashes --no-deps -r installer.lock" in recipe
    assert "$(UV) --require-hashes --no-deps --compile-bytecode -r environment.lock" in recipe
    assert "installer.lock" in recipe.splitlines()[0] and "environment.lock" in recipe.splitlines()[0]


@pytest.mark.parametrize("lock", LOCKS[:2])
def test_the_locks_name_no_folder_of_the_machine_that_compiled_them(lock):
    """pip-compile copies the compiling machine's pip settings (``--find-links /opt/wheels``); uv refuses a
    lock whose folder is missing on the machine that installs it ("relative URL without a base")."""
    assert options(ROOT / lock) == [], f"{lock} has machine-specific options; `make lock` (--no-emit-find-links)"


@pytest.mark.skipif(sys.prefix != str(ROOT / ".venv"), reason="runs in the environment `make env` made (.venv)")
def test_the_environment_is_the_lock():
    installed = {canonical(d.metadata["Name"]): d.version for d in metadata.distributions()}
    wrong = {name: (version, installed.get(name)) for name, version in pins(ROOT / "environment.lock").items()
             if installed.get(name) != version}
    assert not wrong, f".venv differs from environment.lock (name: (lock, installed)): {dict(list(wrong.items())[:5])}"
