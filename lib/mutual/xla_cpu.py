"""XLA:CPU's threshold for compiling a small loop as one function, raised for the compendium.

XLA:CPU runs a ``while`` loop (``lax.scan``, ``fori_loop``, ``while_loop``) that accesses fewer
than ``xla_cpu_small_while_loop_byte_threshold`` bytes as one compiled function, and a larger
one as a kernel launch per operation and iteration. The default, 1 KiB, leaves out the
compendium's small loops (an iLQR pass over 100-400 stages, optax L-BFGS, the compiled Riccati
recursions), whose iterations then cost mostly launches: at 1 MiB an iLQR solve of Fig. 7.2 runs
about 2x faster on 2 cores (``bench/bench_ilqr.py``), while the large loops (HJ reachability, the
Algorithm 4 stencil) are unchanged.

Importing :mod:`mutual` adds the option to ``XLA_FLAGS`` unless it is set already (a value of
your own wins). Like every XLA flag it applies from the first JAX computation of a process, so
import :mod:`mutual` before running JAX code of your own to get it there too.
"""

import os
import re

OPTION = "xla_cpu_small_while_loop_byte_threshold"
SMALL_LOOP_BYTES = 2 ** 20


def with_small_loop_threshold(flags, size=SMALL_LOOP_BYTES):
    """``flags`` (an ``XLA_FLAGS`` string) with ``OPTION=size`` among the backend's extra options,
    unless ``OPTION`` is there already."""
    if OPTION in flags:
        return flags
    extra = re.search(r"--xla_backend_extra_options=(\S*)", flags)
    if extra is None:
        return f"{flags} --xla_backend_extra_options={OPTION}={size}".strip()
    options = ",".join(filter(None, [extra.group(1), f"{OPTION}={size}"]))
    return flags[:extra.start(1)] + options + flags[extra.end(1):]


def use_small_loop_threshold(environ=os.environ):
    """Set ``XLA_FLAGS`` in ``environ`` (see :func:`with_small_loop_threshold`)."""
    environ["XLA_FLAGS"] = with_small_loop_threshold(environ.get("XLA_FLAGS", ""))
