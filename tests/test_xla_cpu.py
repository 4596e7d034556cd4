"""mutual.xla_cpu: the XLA:CPU small-loop threshold that importing mutual sets."""

import os
import subprocess
import sys

from mutual.xla_cpu import OPTION, SMALL_LOOP_BYTES, use_small_loop_threshold, with_small_loop_threshold


def test_the_option_is_added_to_empty_or_unrelated_flags():
    assert with_small_loop_threshold("") == f"--xla_backend_extra_options={OPTION}={SMALL_LOOP_BYTES}"
    assert with_small_loop_threshold("--xla_cpu_enable_fast_math=false", 4096) == (
        f"--xla_cpu_enable_fast_math=false --xla_backend_extra_options={OPTION}=4096")


def test_other_backend_options_are_kept_and_a_value_of_ones_own_wins():
    flags = "--xla_backend_extra_options=xla_cpu_fold_all_constants --xla_dump_to=/tmp/x"
    assert with_small_loop_threshold(flags, 4096) == (
        f"--xla_backend_extra_options=xla_cpu_fold_all_constants,{OPTION}=4096 --xla_dump_to=/tmp/x")
    own = f"--xla_backend_extra_options={OPTION}=64"
    assert with_small_loop_threshold(own) == own
    env = {"XLA_FLAGS": own}
    use_small_loop_threshold(env)
    assert env == {"XLA_FLAGS": own}


def test_importing_mutual_sets_it_and_xla_accepts_it():
    """In a fresh process: ``import mutual`` puts the option in XLA_FLAGS, and XLA parses it (a
    malformed value would make the first computation fail)."""
    code = ("import os, mutual, jax, jax.numpy as jnp; "
            "print(os.environ['XLA_FLAGS']); "
            "print(float(jax.jit(lambda x: jax.lax.fori_loop(0, 5, lambda i, c: c + i, x))(jnp.float32(0))))")
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    flags, value = out.strip().splitlines()[-2:]
    assert f"{OPTION}={SMALL_LOOP_BYTES}" in flags and float(value) == 10.0
