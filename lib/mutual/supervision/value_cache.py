"""The disk cache of converged value functions (``mutual.cache.cache_dir() / "reachability"``).

One ``.npz`` file per library member, named by a key that hashes everything that makes the
member's values: dynamics, obstacle, grid, solver settings, package versions and the solver's own
code (:func:`~.reachability.solver_code_version`). Each file stores the ``values``, the
``horizon``, its ``key``, the parameters that made it (``params``, JSON) and a ``checksum`` of all of
them: an HMAC-SHA256 under the user's secret key (:func:`mutual.cache.sign`, :func:`mutual.cache.secret_key`); it is written atomically as soon as its member converges, so that an
interrupted library build keeps its finished members. Files hold arrays and text only and are
read with ``allow_pickle=False``: nothing in the cache runs when it is loaded.

:func:`load_member` verifies a file before trusting it: it must open, hold exactly the expected
fields with the expected types, the expected key and parameters (not another member's), the grid's
shape, finite values, a matching checksum, and pass the caller's plausibility check of the values
themselves (:func:`~.reachability.value_library` compares the head-on reach of the unsafe set with
the closed form). A file that does not verify is reported with a :class:`CacheWarning` naming its
path and the reason, and the caller recomputes and overwrites it: a damaged cache heals instead of
crashing every run. The checksum guards against damage, mix-ups and forgery: no one without the key (another
user, a copied cache) can make an entry that verifies, and no one else may write the cache folder at all
(:func:`mutual.cache.insecure`); the plausibility check would catch another member's values even then. A cache that cannot be used at all (read-only, full, no home folder, a folder where a
file should be that cannot be removed) leaves the run going without it (:mod:`mutual.cache`).
"""

import hashlib
import hmac
import json
import warnings
import zipfile
import zlib

import numpy as np

from ..cache import CacheWarning, cache_dir, cache_folder, clear_entry, secret_key, sign, write_entry

CACHE_FORMAT = 4
FIELDS = {"values": "f", "horizon": "f", "key": "U", "params": "U", "checksum": "U"}   # name: numpy dtype kind
FOLDER = "reachability"

__all__ = ["CacheWarning", "cache_file", "cache_key", "cache_params", "load_member", "save_member"]


def cache_params(w_max, radius, speed, d_max, spec, solver, versions):
    """Everything that makes a member's values, as plain JSON values (stored in the file and checked on load)."""
    return {"format": CACHE_FORMAT, "w_max": float(w_max), "radius": float(radius), "speed": float(speed),
            "d_max": float(d_max), "grid": [float(spec.half_width), list(spec.shape)],
            "solver": [solver.accuracy, float(solver.chunk_time), float(solver.tolerance), float(solver.max_time)],
            "versions": dict(versions)}


def _params_text(params):
    return json.dumps(params, sort_keys=True)


def cache_key(w_max, radius, speed, d_max, spec, solver, versions):
    """Hex digest of everything that makes a member (:func:`cache_params`)."""
    params = cache_params(w_max, radius, speed, d_max, spec, solver, versions)
    return hashlib.sha256(_params_text(params).encode()).hexdigest()[:20]


def cache_file(key):
    """Where the member with this key is cached (the folder is not created here)."""
    return cache_dir() / FOLDER / f"avoid-{key}.npz"


def _checksum(key, values, horizon, params_text="", secret=None):
    """The HMAC of a member's fields under the user's key (``secret``, default :func:`mutual.cache.secret_key`)."""
    secret = secret_key() if secret is None else secret
    if secret is None:
        raise ValueError("no key to authenticate it with (the cache cannot be used)")
    return sign(secret, key, np.ascontiguousarray(values, dtype=np.float32).tobytes(), np.float64(horizon).tobytes(),
                params_text)


def save_member(key, values, horizon, params):
    """Atomically write one converged member with its key, parameters and checksum; return the path,
    or None when the cache cannot be written (one CacheWarning; the run goes on)."""
    values = np.asarray(values, dtype=np.float32)
    if not np.all(np.isfinite(values)) or not np.isfinite(horizon):
        raise ValueError(f"refusing to cache a member with non-finite values or horizon (key {key})")
    text = _params_text(params)
    if cache_folder(FOLDER) is None or secret_key() is None:
        return None

    def write(tmp):
        with open(tmp, "wb") as handle:
            np.savez(handle, values=values, horizon=np.float64(horizon), key=np.str_(key), params=np.str_(text),
                     checksum=np.str_(_checksum(key, values, horizon, text)))

    return write_entry(cache_file(key), write)


def _read(path):
    """The stored fields of ``path``, each checked for its type (ValueError with the reason)."""
    try:
        stored = np.load(path, allow_pickle=False)
        if not isinstance(stored, np.lib.npyio.NpzFile):
            raise ValueError("a bare array, not an .npz archive")
        with stored:
            names = set(stored.files)
            loaded = {name: stored[name] for name in FIELDS if name in names}
    except (zipfile.BadZipFile, EOFError, OSError, ValueError, zlib.error, KeyError) as err:
        raise ValueError(f"unreadable ({type(err).__name__}: {err})") from None
    missing, extra = set(FIELDS) - names, names - set(FIELDS)
    if missing or extra:
        raise ValueError(f"fields {sorted(names)}, expected {sorted(FIELDS)} (not a cache file of this format)")
    for name, kind in FIELDS.items():
        if loaded[name].dtype.kind != kind or (name != "values" and loaded[name].ndim != 0):
            raise ValueError(f"field {name!r} has dtype {loaded[name].dtype} and shape {loaded[name].shape}")
    return loaded


def _verify(path, key, shape, params, check):
    """``(values, horizon)`` from ``path``, or raise ValueError with the reason it does not verify."""
    loaded = _read(path)
    values, horizon = loaded["values"], float(loaded["horizon"])
    stored_key, text, checksum = str(loaded["key"]), str(loaded["params"]), str(loaded["checksum"])
    if stored_key != key:
        raise ValueError(f"it holds another member (key {stored_key}, expected {key})")
    try:
        stored_params = json.loads(text)
    except ValueError:
        raise ValueError("its parameters are not JSON") from None
    if stored_params != json.loads(_params_text(params)):
        differ = sorted(k for k in set(params) | set(stored_params) if stored_params.get(k) != params.get(k))
        raise ValueError(f"it was made with other parameters ({', '.join(differ)} differ from the request)")
    if values.shape != tuple(shape) or values.dtype != np.float32:
        raise ValueError(f"values have shape {values.shape} and dtype {values.dtype}, expected {tuple(shape)} float32")
    if not np.all(np.isfinite(values)) or not np.isfinite(horizon):
        raise ValueError(f"{int(np.sum(~np.isfinite(values)))} values are NaN or infinite")
    if not hmac.compare_digest(_checksum(key, values, horizon, text), checksum):
        raise ValueError("checksum mismatch (the file was changed after it was written, or written without your key)")
    if check is not None:
        check(values)
    return values, horizon


def load_member(key, shape, params, check=None):
    """The cached ``(values, horizon)`` for ``key``, or ``None``: absent, unusable cache, or a file
    that does not verify (a :class:`CacheWarning` with its path and the reason; the caller recomputes
    and :func:`save_member` overwrites it). ``check(values)`` raises ValueError for implausible values."""
    try:
        path = cache_file(key)
        if not path.exists() and not path.is_symlink():
            return None
    except OSError:   # no home folder: save_member reports it once
        return None
    if cache_folder(FOLDER, writable=False) is None or secret_key() is None:
        return None    # others may write the cache, or no key: nothing in it is trusted
    if path.is_dir() or path.is_symlink():
        if clear_entry(path):
            warnings.warn(f"value-function cache entry {path} was a folder or a link, not a file; removed it "
                          "and recomputing", CacheWarning, stacklevel=3)
        return None
    try:
        return _verify(path, key, shape, params, check)
    except ValueError as err:
        warnings.warn(f"value-function cache file {path} does not verify: {err}; recomputing it", CacheWarning,
                      stacklevel=3)
        return None
