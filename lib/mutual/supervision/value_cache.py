"""The disk cache of converged value functions (``mutual.cache.cache_dir() / "reachability"``).

One ``.npz`` file per library member, named by a key that hashes everything that changes the
member (dynamics, obstacle, grid, solver, package versions). Each file also stores its ``key``
and a SHA-256 ``checksum`` of the key, the values and the horizon, and is written atomically as
soon as its member converges, so that an interrupted library build keeps its finished members.

:func:`load_member` verifies a file before trusting it: it must open, hold the expected key
(not another member's), the grid's shape, finite values and a matching checksum. A file that
does not verify is reported with a :class:`CacheWarning` naming its path and the reason, and
the caller recomputes and overwrites it: a damaged cache heals instead of crashing every run.
"""

import hashlib
import json
import warnings
import zipfile
import zlib

import numpy as np

from ..atomic import atomic_path
from ..cache import cache_dir

CACHE_FORMAT = 2


class CacheWarning(UserWarning):
    """A value-function cache file did not verify and is being rebuilt."""


def cache_key(w_max, radius, speed, d_max, spec, solver, versions):
    """Hex digest of everything that changes a member: dynamics, obstacle, grid, solver, package versions."""
    payload = {"format": CACHE_FORMAT, "w_max": float(w_max), "radius": float(radius), "speed": float(speed),
               "d_max": float(d_max), "grid": [float(spec.half_width), list(spec.shape)],
               "solver": [solver.accuracy, float(solver.chunk_time), float(solver.tolerance),
                          float(solver.max_time)], "versions": versions}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:20]


def cache_file(key):
    """Where the member with this key is cached."""
    return cache_dir() / "reachability" / f"avoid-{key}.npz"


def _checksum(key, values, horizon):
    digest = hashlib.sha256(key.encode())
    digest.update(np.ascontiguousarray(values, dtype=np.float32).tobytes())
    digest.update(np.float64(horizon).tobytes())
    return digest.hexdigest()


def save_member(key, values, horizon):
    """Atomically write one converged member (values, horizon) with its key and checksum; return the path."""
    values = np.asarray(values, dtype=np.float32)
    if not np.all(np.isfinite(values)) or not np.isfinite(horizon):
        raise ValueError(f"refusing to cache a member with non-finite values or horizon (key {key})")
    path = cache_file(key)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as handle:
            np.savez(handle, values=values, horizon=np.float64(horizon), key=np.str_(key),
                     checksum=np.str_(_checksum(key, values, horizon)))
    return path


def _verify(path, key, shape):
    """``(values, horizon)`` from ``path``, or raise ValueError with the reason it does not verify."""
    try:
        with np.load(path, allow_pickle=False) as stored:
            fields = set(stored.files)
            loaded = {name: stored[name] for name in ("values", "horizon", "key", "checksum") if name in fields}
    except (zipfile.BadZipFile, EOFError, OSError, ValueError, zlib.error, KeyError) as err:
        raise ValueError(f"unreadable ({type(err).__name__}: {err})") from None
    missing = {"values", "horizon", "key", "checksum"} - set(loaded)
    if missing:
        raise ValueError(f"missing fields {sorted(missing)} (not a cache file of this format)")
    values, stored_key, checksum = loaded["values"], str(loaded["key"]), str(loaded["checksum"])
    try:
        horizon = float(loaded["horizon"])
    except (TypeError, ValueError):
        raise ValueError(f"horizon {loaded['horizon']!r} is not a number") from None
    if stored_key != key:
        raise ValueError(f"it holds another member (key {stored_key}, expected {key})")
    if values.shape != tuple(shape) or values.dtype != np.float32:
        raise ValueError(f"values have shape {values.shape} and dtype {values.dtype}, expected {tuple(shape)} float32")
    if not np.all(np.isfinite(values)) or not np.isfinite(horizon):
        raise ValueError(f"{int(np.sum(~np.isfinite(values)))} values are NaN or infinite")
    if _checksum(key, values, horizon) != checksum:
        raise ValueError("checksum mismatch (the file was corrupted after it was written)")
    return values, horizon


def load_member(key, shape):
    """The cached ``(values, horizon)`` for ``key``, ``None`` if absent, or ``None`` with a
    :class:`CacheWarning` (path and reason) if the file does not verify; the caller recomputes."""
    path = cache_file(key)
    if not path.exists():
        return None
    try:
        return _verify(path, key, shape)
    except ValueError as err:
        warnings.warn(f"value-function cache file {path} does not verify: {err}; recomputing it", CacheWarning,
                      stacklevel=3)
        return None
