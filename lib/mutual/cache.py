"""Where expensive results are cached: ``$MUTUAL_CACHE_DIR``, else the user's cache folder
(``$XDG_CACHE_HOME/mutual``, by default ``~/.cache/mutual``). The compendium's Makefile points
it at the repository's ``.cache/`` so that ``make clean`` removes it.

Every disk cache of the package goes through the helpers here, so that a cache never stops a
run: a cache folder that cannot be created or written (a read-only disk or folder, an unwritable
or missing home folder, a full disk, a file where a folder should be) and an entry that cannot be
read or replaced (a folder where a file should be) leave the run going without the cache, with
one :class:`CacheWarning` per folder saying where and why. A folder found where an entry should
be is removed, so the cache heals. Entries hold data only (``.npz`` read with
``allow_pickle=False``, JSON), never anything that runs code when it is loaded.
"""

import os
import shutil
import warnings
from pathlib import Path

from .atomic import atomic_path

_WARNED = set()   # folders whose cache was reported unusable in this process (one warning each)


class CacheWarning(RuntimeWarning):
    """A cache entry did not verify and is being rebuilt, or a cache cannot be used and the run goes
    on without it."""


def cache_dir() -> Path:
    """The cache folder (not created here; writers create what they need through :func:`cache_folder`).
    Raises OSError when there is no ``$MUTUAL_CACHE_DIR`` and no home folder to put it in."""
    if os.environ.get("MUTUAL_CACHE_DIR"):
        return Path(os.environ["MUTUAL_CACHE_DIR"])
    if os.environ.get("XDG_CACHE_HOME"):
        return Path(os.environ["XDG_CACHE_HOME"]) / "mutual"
    try:
        return Path.home() / ".cache" / "mutual"
    except (RuntimeError, KeyError):
        raise FileNotFoundError("no home folder to put the cache in (set MUTUAL_CACHE_DIR)") from None


def unusable(where, err, doing="running without it"):
    """Say once per ``where`` (a cache folder) that its cache cannot be used, and why."""
    where = str(where)
    if where in _WARNED:
        return
    _WARNED.add(where)
    reason = f"{type(err).__name__}: {err}" if isinstance(err, BaseException) else str(err)
    warnings.warn(f"the cache in {where} cannot be used ({reason}); {doing}", CacheWarning, stacklevel=3)


def cache_folder(name, writable=True):
    """``cache_dir() / name``, created if needed, or None (one :class:`CacheWarning`) when it cannot
    be created or, with ``writable``, written (a read-only disk or folder, no home folder)."""
    try:
        folder = cache_dir() / name
    except OSError as err:
        unusable("the cache folder", err)
        return None
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if writable and not os.access(folder, os.W_OK | os.X_OK):
            raise PermissionError(f"{folder} is not writable")
    except OSError as err:
        unusable(folder, err)
        return None
    return folder


def clear_entry(path):
    """Make room for the cache entry ``path``: remove a folder (or link) found where the file should be.
    Returns False (one :class:`CacheWarning`) when that cannot be done."""
    path = Path(path)
    try:
        if path.is_symlink():
            path.unlink()
        elif path.is_dir():
            shutil.rmtree(path)
    except OSError as err:
        unusable(path.parent, err)
        return False
    return True


def write_entry(path, write):
    """Atomically write the cache entry ``path`` with ``write(temporary_path)``; return ``path``, or None
    (one :class:`CacheWarning` per folder) when the disk refuses (read-only, full, no permission)."""
    path = Path(path)
    try:
        if not clear_entry(path):
            return None
        with atomic_path(path) as tmp:
            write(tmp)
    except OSError as err:
        unusable(path.parent, err)
        return None
    return path
