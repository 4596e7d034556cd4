"""JAX's persistent compilation cache in the compendium's cache folder.

JAX compiles every jitted function once per process; the compendium's solvers (iLQR, L-BFGS, the
Riccati recursions, the Algorithm 4 stencil, the HJ solver) take 0.2-5 s each to compile, and the
tests, the notebooks, ``make figures`` and the command line compile the same programs again and
again. Importing :mod:`mutual` points JAX's persistent cache at ``<cache folder>/jax``
(:func:`mutual.cache.cache_dir`: ``$MUTUAL_CACHE_DIR``, or ``~/.cache/mutual``), so a program
compiled once is loaded from disk by every later process. Entries are keyed by JAX's own rules
(the program, the JAX and XLA versions, the backend and its flags), so a change of any of them
compiles anew; the folder holds serialised XLA executables, never Python objects.

Nothing is imported and no folder is created here: the settings go into the environment
(``JAX_COMPILATION_CACHE_DIR``, read by JAX when it is imported), or into ``jax.config`` when JAX
was imported before :mod:`mutual`. A cache folder of your own (``JAX_COMPILATION_CACHE_DIR``)
wins, and an unwritable cache folder leaves the cache off (a warning once), never stops a run.
"""

import os
import sys
from pathlib import Path

from .cache import cache_dir, unusable

MIN_COMPILE_SECONDS = 0.0  # every compiled program (JAX's default, 1 s, would leave out most iLQR kernels)
SETTINGS = {"jax_compilation_cache_dir": "JAX_COMPILATION_CACHE_DIR",
            "jax_persistent_cache_min_compile_time_secs": "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"}


def _writable(folder):
    """Whether ``folder`` exists and is writable, or could be created (its nearest existing
    ancestor is a writable directory)."""
    path = Path(folder).absolute()
    while not path.exists():
        path = path.parent
    return path.is_dir() and os.access(path, os.W_OK | os.X_OK)


def use_persistent_cache(environ=os.environ):
    """Turn JAX's persistent compilation cache on in ``<cache folder>/jax`` (see the module)."""
    if environ.get("JAX_COMPILATION_CACHE_DIR"):
        return
    try:
        folder = cache_dir() / "jax"
    except OSError as err:
        unusable("the cache folder", err, "JAX's compilation cache is off")
        return
    if not _writable(folder):
        unusable(folder, f"{folder} is not writable", "JAX's compilation cache is off (set MUTUAL_CACHE_DIR to a "
                 "writable folder to keep compiled programs between runs)")
        return
    values = {"jax_compilation_cache_dir": str(folder), "jax_persistent_cache_min_compile_time_secs":
              environ.get("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", str(MIN_COMPILE_SECONDS))}
    for option, variable in SETTINGS.items():
        environ[variable] = values[option]
    if "jax" in sys.modules:  # imported before mutual: its flags were read already
        import jax
        jax.config.update("jax_compilation_cache_dir", values["jax_compilation_cache_dir"])
        jax.config.update("jax_persistent_cache_min_compile_time_secs",
                          float(values["jax_persistent_cache_min_compile_time_secs"]))
