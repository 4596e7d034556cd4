"""Monte Carlo sweeps on Dask: the same code on 2 cores or on a cluster.

:func:`run_tasks` maps a task function over task objects with :func:`mutual.parallel.map_tasks`:

* by default on an embedded private cluster, one single-threaded worker process per core, that accepts
  only this process (TLS with a throwaway certificate; :func:`mutual.parallel.private_cluster`);
* or on an existing cluster reached by address: ``scheduler="tcp://host:8786"``, or the
  ``MUTUAL_DASK_SCHEDULER`` environment variable (start one with ``dask scheduler`` and
  ``dask worker tcp://host:8786`` on each machine, or with dask-jobqueue on SLURM: README);
* or ``scheduler="inline"``: in this process, without Dask (a reference and for debugging).

Large read-only inputs (the value functions) are sent once to every worker (``shared``) and stay in
its memory. Each task's result (a table) is cached by the client as JSON in a folder keyed by the
task's parameters and a code version (atomic writes; :class:`TaskCache`: nothing in it can run code
when loaded), so an interrupted sweep resumes where it stopped. A task's
result depends only on its parameters (its seed is derived from them), so results are identical
whatever the number of workers or the order they finish in. Progress is shown with tqdm
(silenced by ``TQDM_DISABLE=1``).
"""

import hashlib
import hmac
import json
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from tqdm.auto import tqdm

from ..cache import CacheWarning, cache_folder, secret_key, sign, unusable, usable_folder, write_entry
from ..parallel import INLINE, SCHEDULER_ENV, dask_client, map_tasks, scheduler_address  # noqa: F401 (the sweep's words)

CACHE_FORMAT = 2
_COLUMN_TYPES = {"float64": (float, int), "int64": (int,), "bool": (bool,), "object": (str, type(None)),
                 "str": (str, type(None))}


class TaskCache:
    """Results of finished tasks in ``folder`` (default ``<cache dir>/power``), one JSON file per task,
    named by the hash of the task's parameters and ``version`` (the code that computes them).

    A result is a pandas DataFrame whose columns hold floats, whole numbers, booleans or text (None
    allowed); numbers are written exactly (JSON's shortest round-trip form). JSON cannot run code when
    it is read, and :meth:`get` checks what it reads: its HMAC under the user's secret key (no one without
    the key can forge an entry; :mod:`mutual.cache`), the format, the task's key, the column names and
    every value's type; a folder that others may write is not used at all. A file that does not verify is deleted with a :class:`mutual.cache.CacheWarning`
    and the task recomputed; a folder found where a file should be is removed when the result is written
    (the cache heals). A cache folder that cannot be created or written turns the cache off for the
    rest of the sweep with one warning (:mod:`mutual.cache`); the sweep goes on.
    """

    def __init__(self, version, folder=None):
        if not isinstance(version, str) or not version:
            raise ValueError(f"version must be a non-empty string, got {version!r}")
        self.version = version
        self.folder = Path(folder) if folder is not None else cache_folder("power")
        self.disabled = self.folder is None
        self._secret = None

    def _usable(self):
        """Whether the cache may be used: its folder is this user's alone and the user's key is there (checked once)."""
        if not self.disabled and self._secret is None:
            self._secret = usable_folder(self.folder) and secret_key()
            self.disabled = not self._secret
        return not self.disabled

    def __repr__(self):
        return f"TaskCache({str(self.folder)!r}, version={self.version!r})"

    def key(self, params):
        text = json.dumps({"params": params, "version": self.version}, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:32]

    def path(self, params):
        return self.folder / f"{self.key(params)}.json"

    def get(self, params):
        """The cached result, or None: absent, a folder in its place, or not verifying (then deleted)."""
        if not self._usable():
            return None
        path, key = self.path(params), self.key(params)
        try:
            text = path.read_text(encoding="utf-8")
        except (FileNotFoundError, IsADirectoryError, NotADirectoryError):
            return None
        except PermissionError as err:
            self.disabled = True
            unusable(self.folder, err)
            return None
        except (OSError, UnicodeDecodeError) as err:
            return self._heal(path, f"unreadable ({type(err).__name__})")
        try:
            return _frame_from(self._authentic(json.loads(text)), key)
        except (ValueError, TypeError, KeyError, AttributeError) as err:
            return self._heal(path, str(err))

    def put(self, params, result):
        """Store ``result`` (a DataFrame, see the class docstring); a disk that refuses turns the cache off."""
        if not self._usable():
            return
        body = _frame_to(result, self.key(params), self.version, params)
        text = json.dumps({**body, "mac": sign(self._secret, json.dumps(body, sort_keys=True))}, allow_nan=True)
        if write_entry(self.path(params), lambda tmp: tmp.write_text(text, encoding="utf-8")) is None:
            self.disabled = True

    def _authentic(self, stored):
        """``stored`` without its "mac", when the mac is the HMAC of the rest under the user's key (else ValueError)."""
        body = dict(stored) if isinstance(stored, dict) else {}
        mac = body.pop("mac", None)
        if not isinstance(mac, str) or not hmac.compare_digest(mac, sign(self._secret, json.dumps(body, sort_keys=True))):
            raise ValueError("its authentication code does not match (changed after it was written, or written "
                             "without your key)")
        return body

    def _heal(self, path, reason):
        warnings.warn(f"power cache file {path} does not verify: {reason}; recomputing it", CacheWarning,
                      stacklevel=3)
        try:
            path.unlink()
        except OSError:
            pass
        return None


def _frame_to(frame, key, version, params):
    """The JSON-able form of a DataFrame of float, int64, bool and text columns."""
    import pandas as pd
    if not isinstance(frame, pd.DataFrame):
        raise ValueError(f"TaskCache stores pandas DataFrames, got {type(frame).__name__}")
    columns, dtypes, data = [str(c) for c in frame.columns], [], []
    if len(set(columns)) != len(columns) or list(frame.columns) != columns:
        raise ValueError(f"TaskCache needs distinct text column names, got {list(frame.columns)}")
    for name in columns:
        column = frame[name]
        kind = str(column.dtype) if str(column.dtype) in _COLUMN_TYPES else None
        kind = "object" if kind is None and column.dtype == object else kind
        values = column.tolist()
        if kind == "str":                  # pandas' text dtype: a missing value is NaN
            values = [None if isinstance(v, float) else v for v in values]
        if kind is None or (kind in ("object", "str") and not all(isinstance(v, (str, type(None))) for v in values)):
            raise ValueError(f"TaskCache stores float64, int64, bool and text columns; {name!r} is {column.dtype}")
        data.append([float(v) if kind == "float64" else int(v) if kind == "int64" else bool(v) if kind == "bool"
                     else v for v in values])
        dtypes.append(kind)
    return {"format": CACHE_FORMAT, "key": key, "version": version, "params": params, "columns": columns,
            "dtypes": dtypes, "data": data}


def _frame_from(stored, key):
    """The DataFrame of a stored task, after checking every field and value type; ValueError says what is wrong."""
    import numpy as np
    import pandas as pd
    if not isinstance(stored, dict) or stored.get("format") != CACHE_FORMAT:
        raise ValueError(f"not a task cache file of format {CACHE_FORMAT}")
    if stored.get("key") != key:
        raise ValueError(f"it holds another task (key {stored.get('key')!r}, expected {key})")
    columns, dtypes, data = stored["columns"], stored["dtypes"], stored["data"]
    if not (isinstance(columns, list) and isinstance(dtypes, list) and isinstance(data, list)
            and len(columns) == len(dtypes) == len(data) and all(isinstance(c, str) for c in columns)
            and len(set(columns)) == len(columns)):
        raise ValueError("columns, dtypes and data do not match")
    if len({len(values) if isinstance(values, list) else -1 for values in data}) > 1:
        raise ValueError("columns of different lengths")
    out = {}
    for name, kind, values in zip(columns, dtypes, data):
        allowed = _COLUMN_TYPES.get(kind)
        if not isinstance(values, list) or allowed is None:
            raise ValueError(f"column {name!r}: unknown type {kind!r}")
        if not all(isinstance(v, allowed) and (kind in ("bool", "object") or not isinstance(v, bool)) for v in values):
            raise ValueError(f"column {name!r}: a value is not of type {kind}")
        if kind == "float64":
            out[name] = np.array(values, dtype=float)
        elif kind == "int64" and not all(abs(v) < 2 ** 63 for v in values):
            raise ValueError(f"column {name!r}: a whole number beyond 64 bits")
        elif kind == "str":
            out[name] = pd.array(values, dtype="str")
        else:
            out[name] = pd.Series(values, dtype={"int64": np.int64, "bool": bool}.get(kind, object))
    return pd.DataFrame(out, columns=columns)


@dataclass
class SweepStats:
    """What a sweep did: tasks, those read from the cache, computed, workers, wall-clock seconds."""
    tasks: int = 0
    cached: int = 0
    computed: int = 0
    workers: int = 0
    seconds: float = 0.0
    where: str = ""
    task_seconds: list = field(default_factory=list, repr=False)


def run_tasks(fn, tasks, params=None, shared=(), cache=None, scheduler=None, workers=None, client=None,
              progress=True, desc="tasks", verify=True):
    """``[fn(task, *shared) for task in tasks]`` on Dask (module docstring), in task order.

    ``params(task)`` gives the task's parameters as JSON-able data (default ``task.params()``), the
    cache key with ``cache.version``. ``client``: an open ``distributed.Client`` (else one is made
    from ``scheduler`` / ``workers`` for this call). ``verify``: recompute one cached result in this
    process and compare it with the cache's (a task is cheap beside a sweep); when they differ, nothing
    in the cache is used for this sweep. Returns ``(results, SweepStats)``.
    """
    tasks = list(tasks)
    params = params or (lambda t: t.params())
    start = time.perf_counter()
    results = [cache.get(params(t)) if cache is not None else None for t in tasks]
    if verify and not _reproduces(fn, tasks, shared, results, params, cache):
        results = [None] * len(tasks)
    todo = [i for i, r in enumerate(results) if r is None]
    stats = SweepStats(tasks=len(tasks), cached=len(tasks) - len(todo), computed=len(todo))
    bar = tqdm(total=len(tasks), initial=stats.cached, desc=desc, disable=not progress or None)
    version = cache.version if cache is not None else "uncached"

    def done(j, timed):
        i = todo[j]
        results[i], seconds = timed
        stats.task_seconds.append(seconds)
        if cache is not None:
            cache.put(params(tasks[i]), results[i])
        bar.update(1)

    def key(task):
        return hashlib.sha256(json.dumps([params(task), version], sort_keys=True, default=str).encode()).hexdigest()[:24]

    try:
        if todo:
            _, ran = map_tasks(_Timed(fn), [tasks[i] for i in todo], shared, scheduler, workers, client, done, key)
            stats.where, stats.workers = ran.where, ran.workers
    finally:
        bar.close()
    stats.seconds = time.perf_counter() - start
    return results, stats


def _reproduces(fn, tasks, shared, results, params, cache):
    """Whether the first cached result equals its recomputation (True when nothing came from the cache)."""
    cached = [i for i, r in enumerate(results) if r is not None]
    if not cached:
        return True
    i = cached[0]
    again = fn(tasks[i], *shared)
    same = again.equals(results[i]) if hasattr(again, "equals") else again == results[i]
    if not same:
        warnings.warn(f"power cache in {cache.folder}: the cached result of {params(tasks[i])} differs from its "
                      "recomputation; nothing in the cache is used for this sweep", CacheWarning, stacklevel=3)
    return bool(same)


class _Timed:
    """``fn`` returning ``(result, seconds)``; named as ``fn`` for the task keys."""

    def __init__(self, fn):
        self.fn, self.__name__ = fn, getattr(fn, "__name__", "task")

    def __call__(self, task, *shared):
        start = time.perf_counter()
        result = self.fn(task, *shared)
        return result, time.perf_counter() - start


def noop(task):
    """A task that does nothing (measures the per-task overhead of the machinery)."""
    return task
