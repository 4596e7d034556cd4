"""mutual.jax_cache: importing mutual turns on JAX's persistent compilation cache in the
compendium's cache folder; a second process loads what the first compiled."""

import os
import subprocess
import sys

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
    assert folder == str(tmp_path / "jax") and any((tmp_path / "jax").iterdir())
    second, warm_hits, _ = _run(env)
    assert cold_hits == 0 and warm_hits >= 1 and second == first


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
