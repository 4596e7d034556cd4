"""mutual.jax_cache: importing mutual turns on JAX's persistent compilation cache in the
compendium's cache folder; a second process loads what the first compiled."""

import functools
import os
import subprocess
import sys

import jax  # noqa: F401 (imported here, so use_persistent_cache says at once why the cache is off)
import pytest

from mutual import jax_cache

# a program compiled in a fresh process; prints how many persistent-cache hits JAX reported
PROGRAM = """
import jax, jax.numpy as jnp, mutual
from jax import monitoring
hits = []
monitoring.register_event_listener(lambda event, **kw: hits.append(event) if event.endswith("cache_hits") else None)
f = jax.jit(lambda x: jax.lax.fori_loop(0, 7, lambda i, c: jnp.sin(c) + i, x))
print(float(f(jnp.float32(0.5))), len(hits), jax.config.jax_compilation_cache_dir)
"""


def _run(env):
    out = subprocess.run([sys.executable, "-c", PROGRAM], capture_output=True, text=True, env=env, check=True)
    value, hits, folder = out.stdout.split()
    return float(value), int(hits), folder


def _env(**extra):
    env = {k: v for k, v in os.environ.items() if not k.startswith("JAX_")}
    return {**env, **extra}


def test_a_second_process_loads_what_the_first_compiled(tmp_path):
    env = _env(MUTUAL_CACHE_DIR=str(tmp_path))
    first, cold_hits, folder = _run(env)
    assert folder == str(tmp_path / jax_cache.FOLDER) and any((tmp_path / jax_cache.FOLDER).iterdir())
    second, warm_hits, _ = _run(env)
    assert cold_hits == 0 and warm_hits >= 1 and second == first


def test_a_cache_folder_changed_after_import_keeps_the_programs_key(tmp_path):
    """A process that points MUTUAL_CACHE_DIR elsewhere after importing mutual (a notebook, a test) still writes its
    programs to the first folder, so it signs them with that folder's key: the next process runs them, no warning."""
    elsewhere = f"import os; os.environ['MUTUAL_CACHE_DIR'] = {str(tmp_path / 'b')!r}\n"
    moved = PROGRAM.replace("from jax import monitoring", elsewhere + "from jax import monitoring")
    env = _env(MUTUAL_CACHE_DIR=str(tmp_path / "a"))
    subprocess.run([sys.executable, "-c", moved], capture_output=True, text=True, env=env, check=True)
    out = subprocess.run([sys.executable, "-c", PROGRAM], capture_output=True, text=True, env=env, check=True)
    assert int(out.stdout.split()[1]) >= 1 and "does not verify" not in out.stderr, out.stderr


# a process that imported mutual runs sys.argv[1] in a child process, which inherits JAX_COMPILATION_CACHE_DIR
INHERITS = "import mutual, subprocess, sys; sys.exit(subprocess.run([sys.executable, '-c', sys.argv[1]]).returncode)"


def test_a_child_process_signs_and_reads_the_cache_it_inherits(tmp_path):
    """A notebook's kernel, a Dask worker or a subprocess inherits the JAX cache folder mutual set: it signs what
    it writes there (a fresh process runs it, no warning) and runs what is signed (no undecodable entry)."""
    env = _env(MUTUAL_CACHE_DIR=str(tmp_path))
    python = functools.partial(subprocess.run, capture_output=True, text=True, env=env, check=True)
    child = python([sys.executable, "-c", INHERITS, PROGRAM])
    fresh = python([sys.executable, "-c", PROGRAM])
    assert int(fresh.stdout.split()[1]) >= 1 and "does not verify" not in fresh.stderr, fresh.stderr
    again = python([sys.executable, "-c", INHERITS, PROGRAM])
    assert int(again.stdout.split()[1]) >= 1 and "Error reading" not in again.stderr, again.stderr
    assert child.stdout.split()[2] == fresh.stdout.split()[2] == str(tmp_path / jax_cache.FOLDER)


def test_an_inherited_folder_that_others_may_write_is_not_used(tmp_path):
    """A child's inherited signed folder passes the same checks as its parent's: world-writable, the cache is off."""
    (tmp_path / "x" / jax_cache.FOLDER).mkdir(parents=True)
    (tmp_path / "x").chmod(0o777)
    env = _env(MUTUAL_CACHE_DIR=str(tmp_path / "x"), JAX_COMPILATION_CACHE_DIR=str(tmp_path / "x" / jax_cache.FOLDER),
               MUTUAL_JAX_CACHE_ROOT=str(tmp_path / "x"))
    out = subprocess.run([sys.executable, "-c", PROGRAM], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.split()[2] == "None" and "can be written by anyone" in out.stderr, out.stderr


def test_a_folder_of_ones_own_named_jax_signed_stays_ones_own(tmp_path):
    """Only the folder mutual chose is signed (its variables say so): no key is made beside a folder of the user's."""
    own = tmp_path / jax_cache.FOLDER
    _, _, folder = _run(_env(MUTUAL_CACHE_DIR=str(tmp_path / "ours"), JAX_COMPILATION_CACHE_DIR=str(own)))
    assert folder == str(own) and not (tmp_path / "key").exists() and not (tmp_path / "ours").exists()


def test_a_cache_folder_of_ones_own_wins(tmp_path):
    own = tmp_path / "own"
    _, _, folder = _run(_env(MUTUAL_CACHE_DIR=str(tmp_path / "ours"), JAX_COMPILATION_CACHE_DIR=str(own)))
    assert folder == str(own) and not (tmp_path / "ours").exists()


def test_an_unwritable_cache_folder_leaves_the_cache_off_with_a_warning(tmp_path, monkeypatch):
    """A read-only folder (os.access says so; root may write anyway, so it is simulated here)."""
    monkeypatch.setattr(jax_cache.os, "access", lambda path, mode: False)
    monkeypatch.setenv("MUTUAL_CACHE_DIR", str(tmp_path / "cache"))
    env = {}
    with pytest.warns(RuntimeWarning, match="not writable"):
        jax_cache.use_persistent_cache(env)
    assert env == {}


def test_a_file_where_the_folder_should_be_leaves_the_cache_off(tmp_path, monkeypatch):
    (tmp_path / "cache").write_text("not a folder")
    monkeypatch.setenv("MUTUAL_CACHE_DIR", str(tmp_path / "cache"))
    env = {}
    with pytest.warns(RuntimeWarning, match="not writable"):
        jax_cache.use_persistent_cache(env)
    assert env == {}


# two programs of one shape: swapping their cache entries made a fresh process compute v + 0.5 for v - 0.5
SWAPPED = """
import jax, jax.numpy as jnp, mutual
f = jax.jit(lambda v: v - 0.5)
g = jax.jit(lambda v: v + 0.5)
print(float(f(jnp.float32(2.0))), float(g(jnp.float32(2.0))))
"""


def _programs(env, program=SWAPPED):
    out = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, env=env, check=True)
    return tuple(float(v) for v in out.stdout.split()), out.stderr


def _lambdas(folder):
    return sorted(p for p in (folder / jax_cache.FOLDER).iterdir() if p.name.startswith("jit__lambda"))


def _swap(a, b):
    data = a.read_bytes()
    a.write_bytes(b.read_bytes())
    b.write_bytes(data)


@pytest.mark.parametrize("first", ["jax", "mutual"])  # mutual first: JAX's cache module is wrapped as it loads
@pytest.mark.parametrize("how", ["entries swapped", "an entry without its authentication code"])
def test_a_replaced_compiled_program_is_never_run(tmp_path, how, first):
    env = _env(MUTUAL_CACHE_DIR=str(tmp_path))
    program = SWAPPED if first == "jax" else SWAPPED.replace("import jax, jax.numpy as jnp, mutual",
                                                             "import mutual\nimport jax, jax.numpy as jnp")
    run = functools.partial(_programs, program=program)
    assert run(env)[0] == (1.5, 2.5)
    first, second = _lambdas(tmp_path)
    if how == "entries swapped":
        _swap(first, second)
    else:                                   # JAX's own format, as anyone without the key could write it
        first.write_bytes(second.read_bytes()[32:])
    values, err = run(env)
    assert values == (1.5, 2.5) and "does not verify" in err and "not run" in err
    values, err = run(env)                  # healed: compiled anew and stored with its code
    assert values == (1.5, 2.5) and "does not verify" not in err


def test_a_cache_folder_others_may_write_is_not_used(tmp_path, monkeypatch):
    shared = tmp_path / "shared"
    (shared / jax_cache.FOLDER).mkdir(parents=True)
    shared.chmod(0o777)
    monkeypatch.setenv("MUTUAL_CACHE_DIR", str(shared))
    env = {}
    with pytest.warns(RuntimeWarning, match=f"{shared} can be written by anyone .*rm -rf {shared}"):
        jax_cache.use_persistent_cache(env)
    assert env == {}


def test_a_jax_cache_folder_of_ones_own_that_others_may_write_is_refused(tmp_path):
    own = tmp_path / "own"
    own.mkdir()
    own.chmod(0o777)
    env = {"JAX_COMPILATION_CACHE_DIR": str(own)}
    with pytest.warns(RuntimeWarning, match="can be written by anyone.*JAX's compilation cache is off"):
        jax_cache.use_persistent_cache(env)
    assert env == {}


# a user script, then a command whose handler imports JAX, each in a fresh process with a cache folder others may write
IMPORTS = "import mutual\nprint('imported', flush=True)\nimport jax\n"
COMMAND = """import argparse, sys
from mutual.cli import common
sys.exit(common.run(argparse.Namespace(handler=lambda args: __import__("jax")), "mutual"))
"""


@pytest.mark.parametrize("program, expected", [
    (IMPORTS, "{script}:3: CacheWarning: the cache in {folder} cannot be used"),    # the line that imports JAX
    (COMMAND, "mutual: warning: the cache in {folder} cannot be used"),           # the command line's one line
])
def test_why_the_jax_cache_is_off_is_said_once_when_jax_is_imported(tmp_path, program, expected):
    """Importing mutual alone says nothing (a command that never compiles has no use for the cache); the
    reason comes when JAX is imported, in Python's form for a script and in the command line's own
    one-line form, and only once."""
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    script = tmp_path / "script.py"
    script.write_text(program)
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         env=_env(MUTUAL_CACHE_DIR=str(shared)), check=True)
    first = expected.format(script=script, folder=shared / jax_cache.FOLDER)
    assert out.stderr.startswith(first) and out.stderr.count("cannot be used") == 1, out.stderr
    assert "can be written by anyone" in out.stderr and "rm -rf" in out.stderr
