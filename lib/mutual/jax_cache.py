"""JAX's persistent compilation cache in the compendium's cache folder.

JAX compiles every jitted function once per process; the compendium's solvers (iLQR, L-BFGS, the
Riccati recursions, the Algorithm 4 stencil, the HJ solver) take 0.2-5 s each to compile, and the
tests, the notebooks, ``make figures`` and the command line compile the same programs again and
again. Importing :mod:`mutual` points JAX's persistent cache at ``<cache folder>/jax-signed``
(:func:`mutual.cache.cache_dir`: ``$MUTUAL_CACHE_DIR``, or ``~/.cache/mutual``), so a program
compiled once is loaded from disk by every later process. Entries are keyed by JAX's own rules
(the program, the JAX and XLA versions, the backend and its flags), so a change of any of them
compiles anew; the folder holds serialised XLA executables, never Python objects.

Nothing is imported and no folder is created here: the settings go into the environment
(``JAX_COMPILATION_CACHE_DIR``, read by JAX when it is imported), or into ``jax.config`` when JAX
was imported before :mod:`mutual`. A cache folder of your own (``JAX_COMPILATION_CACHE_DIR``)
wins, and an unwritable cache folder leaves the cache off (a warning once, when JAX is imported), never
stops a run.

JAX runs what it loads from its cache as machine code, and its own cache has no authentication (JAX's
documentation: sharing the cache is letting anyone who may write it run code as you). So, as for every
cache of :mod:`mutual.cache`: a cache folder that others may write, or that is not yours, is not used
(:func:`mutual.cache.insecure`; your own ``JAX_COMPILATION_CACHE_DIR`` too), and each entry in
``<cache folder>/jax-signed`` carries an HMAC-SHA256 of its key and content under your secret key
(:func:`authenticate_entries`): an executable replaced, swapped with another entry or planted without
the key does not verify, is deleted, and is compiled anew (a warning says so), instead of running as is or
failing with an XLA layout error. This wraps JAX's file cache through its internal
``jax._src.compilation_cache.get_file_cache``, hooked when JAX is imported; with a JAX where that is gone,
the cache stays off (a warning), never unauthenticated.
"""

import hashlib
import hmac
import importlib.abc
import importlib.util
import os
import sys
import warnings
from pathlib import Path

from .atomic import atomic_path
from .cache import CacheWarning, advice, cache_dir, insecure, secret_key, unusable

FOLDER = "jax-signed"       # entries with their HMAC (the unsigned ones of "jax" are never read)
ROOT_ENV = "MUTUAL_JAX_CACHE_ROOT"  # set beside JAX_COMPILATION_CACHE_DIR: the cache folder whose key signs it
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
    """Turn JAX's persistent compilation cache on in ``<cache folder>/jax-signed``, with authenticated entries (see
    the module); refuse a folder, ours or yours, that others may write. Why the cache is off is said when JAX
    is imported (at once if it was already), so a command that never compiles says nothing and the command
    line shows it in its own one-line form. A child process (a notebook's kernel, a Dask worker, a subprocess)
    inherits both ``JAX_COMPILATION_CACHE_DIR`` and ``MUTUAL_JAX_CACHE_ROOT``, the cache folder whose key signs it:
    it signs what it writes there and reads what is signed, as its parent does."""
    own = environ.get("JAX_COMPILATION_CACHE_DIR")
    root = _inherited(own, environ)
    if own and root is None:
        reason = insecure(own)
        if reason:
            _when_jax_loads(own, reason, f"JAX's compilation cache is off; make {own} yours alone (chmod -R go-w {own}) "
                                  f"or unset JAX_COMPILATION_CACHE_DIR; clearing it is safe: rm -rf {own}")
            _off(environ, own)
        return
    try:
        root = root or cache_dir().absolute()  # absolute: a child process in another folder finds it too
    except OSError as err:
        _when_jax_loads("the cache folder", err, "JAX's compilation cache is off")
        return _off(environ, own)
    folder = root / FOLDER
    if not _writable(folder):
        _when_jax_loads(folder, f"{folder} is not writable", "JAX's compilation cache is off (set MUTUAL_CACHE_DIR to a "
                 "writable folder to keep compiled programs between runs)")
        return _off(environ, folder)
    reason = insecure(folder)
    if reason:
        _when_jax_loads(folder, reason, "JAX's compilation cache is off; " + advice(folder).removeprefix("running without it; "))
        return _off(environ, folder)
    authenticate_entries(folder, root)
    values = {"jax_compilation_cache_dir": str(folder), "jax_persistent_cache_min_compile_time_secs":
              environ.get("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", str(MIN_COMPILE_SECONDS))}
    for option, variable in SETTINGS.items():
        environ[variable] = values[option]
    environ[ROOT_ENV] = str(root)
    if "jax" in sys.modules:  # imported before mutual: its flags were read already
        import jax
        jax.config.update("jax_compilation_cache_dir", values["jax_compilation_cache_dir"])
        jax.config.update("jax_persistent_cache_min_compile_time_secs",
                          float(values["jax_persistent_cache_min_compile_time_secs"]))


def _inherited(own, environ):
    """The cache folder whose key signs ``own`` when a process that imported mutual set both (an absolute
    ``MUTUAL_JAX_CACHE_ROOT`` with ``own`` its ``jax-signed``); None for a folder of the user's own."""
    root = environ.get(ROOT_ENV)
    if own and root and Path(root).is_absolute() and Path(own) == Path(root) / FOLDER:
        return Path(root)
    return None


def _off(environ, folder):
    """No persistent cache in ``folder`` for this process or its children: the variables cleared, and JAX's
    setting if JAX read it already."""
    environ.pop("JAX_COMPILATION_CACHE_DIR", None)
    environ.pop(ROOT_ENV, None)
    if "jax" in sys.modules and folder is not None:
        import jax
        if str(jax.config.jax_compilation_cache_dir) == str(folder):
            jax.config.update("jax_compilation_cache_dir", None)


def _when_jax_loads(where, reason, doing):
    """:func:`mutual.cache.unusable` now if JAX is imported, else the moment it is."""
    if "jax" in sys.modules:
        unusable(where, reason, doing)
    else:
        sys.meta_path.insert(0, _OnExecute("jax", before=lambda level: unusable(where, reason, doing, level)))


class _OnExecute(importlib.abc.MetaPathFinder):
    """Runs ``before(stacklevel)`` and ``after(module)`` (either may be None) once, when the module ``name`` is
    executed (imported, not merely looked up), around its execution; ``stacklevel`` is that of the line that
    imports it. The import itself is the other finders' and goes on unchanged."""

    def __init__(self, name, before=None, after=None):
        self.name, self.before, self.after = name, before, after

    def find_spec(self, name, path, target=None):
        if name != self.name:
            return None
        spec = next((s for s in (f.find_spec(name, path, target) for f in sys.meta_path
                                 if f is not self and hasattr(f, "find_spec")) if s is not None), None)
        if spec is None or spec.loader is None:
            return spec
        execute, finder = spec.loader.exec_module, self

        def exec_module(module):
            first = finder in sys.meta_path
            if first:
                sys.meta_path.remove(finder)
                if finder.before is not None:  # warnings.warn counts unusable 1, before 2, here 3, then skips
                    finder.before(4)           # the import machinery
            execute(module)
            if first and finder.after is not None:
                finder.after(module)

        spec.loader.exec_module = exec_module
        return spec


TARGET = "jax._src.compilation_cache"
MAC_BYTES = 32
_REPORTED = set()


def authenticate_entries(folder, root):
    """Make JAX's file cache in ``folder`` keep an HMAC with each entry under the key of the cache folder ``root``
    and drop entries that do not verify (module docstring): now if JAX's cache module is loaded, else when it is.
    The key stays ``root``'s for the whole process: a ``MUTUAL_CACHE_DIR`` changed later (by a notebook, a test)
    moves the other caches, not the key of the programs in ``folder``."""
    if TARGET in sys.modules:
        _wrap(sys.modules[TARGET], folder, root)
    elif not any(isinstance(f, _OnExecute) and f.name == TARGET for f in sys.meta_path):
        sys.meta_path.insert(0, _OnExecute(TARGET, after=lambda module: _wrap(module, folder, root)))


def _wrap(module, folder, root):
    """Wrap ``module.get_file_cache`` (and a cache it made already) for ``folder``; without them, no cache."""
    original = getattr(module, "get_file_cache", None)
    if original is None or getattr(original, "authenticated", False) or not hasattr(module, "_cache"):
        if original is None:
            warnings.warn("JAX's compilation cache is off: this JAX version has no get_file_cache to authenticate "
                          "its entries with", CacheWarning, stacklevel=2)
            module.get_file_cache = lambda path: None
        return
    mine = os.path.realpath(folder)

    def get_file_cache(path):
        found = original(path)
        if found is None or os.path.realpath(str(path)) != mine:
            return found
        return _authenticated(found[0], root), found[1]

    get_file_cache.authenticated = True
    module.get_file_cache = get_file_cache
    if module._cache is not None and os.path.realpath(str(module._cache._path)) == mine:
        module._cache = _authenticated(module._cache, root)


def write_text_bytes(path, data):
    """Atomically write ``data`` to ``path`` (:func:`mutual.atomic.atomic_path`)."""
    with atomic_path(path, suffix="") as tmp:
        tmp.write_bytes(data)


def _mac(secret, key, value):
    return hmac.new(secret, b"jax\0" + key.encode() + b"\0" + bytes(value), hashlib.sha256).digest()


def _authenticated(base, root):
    """JAX's cache ``base`` with an HMAC under ``root``'s key before each entry (a CacheInterface)."""
    from jax._src.compilation_cache_interface import CacheInterface

    class AuthenticatedEntries(CacheInterface):
        def __init__(self, inner):
            self._inner, self._path = inner, inner._path

        def get(self, key):
            stored, secret = self._inner.get(key), secret_key(root)
            if stored is None or secret is None:
                return None
            mac, value = stored[:MAC_BYTES], stored[MAC_BYTES:]
            if hmac.compare_digest(mac, _mac(secret, key, value)):
                return value
            entry = Path(str(self._path)) / f"{key}-cache"
            try:
                entry.unlink()          # JAX's put keeps an existing entry: make room for the fresh one
            except OSError:
                pass
            if str(self._path) not in _REPORTED:
                _REPORTED.add(str(self._path))
                warnings.warn(f"a compiled program in JAX's cache {entry} does not verify (changed after it was "
                              "written, or written without your key): not run; compiling it anew", CacheWarning,
                              stacklevel=2)
            return None

        def put(self, key, value):
            secret = secret_key(root)
            if secret is None:
                return
            stored = _mac(secret, key, value) + bytes(value)
            entry = Path(str(self._path)) / f"{key}-cache"
            if getattr(self._inner, "eviction_enabled", False) or entry.exists():
                self._inner.put(key, stored)        # JAX's own bookkeeping (a size limit), or keep the entry
                return
            try:
                write_text_bytes(entry, stored)     # whole or not at all: another process never reads half
            except OSError:
                pass

    return AuthenticatedEntries(base)
