"""Monte Carlo sweeps on Dask (issue 16): the same code on 2 cores or on a cluster.

:func:`run_tasks` maps a task function over task objects on a ``dask.distributed`` cluster:

* by default an embedded ``LocalCluster`` with one single-threaded worker process per core;
* or an existing cluster reached by address: ``scheduler="tcp://host:8786"``, or the
  ``MUTUAL_DASK_SCHEDULER`` environment variable (start one with ``dask scheduler`` and
  ``dask worker tcp://host:8786`` on each machine, or with dask-jobqueue on SLURM: README);
* or ``scheduler="inline"``: in this process, without Dask (a reference and for debugging).

Large read-only inputs (the value functions) are sent once to every worker (``shared``) and stay in
its memory. Each task's result is cached by the client in a folder keyed by the task's parameters
and a code version (atomic writes), so an interrupted sweep resumes where it stopped. A task's
result depends only on its parameters (its seed is derived from them), so results are identical
whatever the number of workers or the order they finish in. Progress is shown with tqdm
(silenced by ``TQDM_DISABLE=1``).
"""

import hashlib
import json
import logging
import os
import pickle
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from tqdm.auto import tqdm

from ..atomic import atomic_path
from ..cache import cache_dir

SCHEDULER_ENV = "MUTUAL_DASK_SCHEDULER"
INLINE = "inline"


def scheduler_address(scheduler=None):
    """The scheduler to use: ``scheduler`` if given, else ``$MUTUAL_DASK_SCHEDULER``, else None
    (an embedded LocalCluster)."""
    if scheduler is not None and not isinstance(scheduler, str):
        raise ValueError(f"scheduler must be an address string or {INLINE!r}, got {scheduler!r}")
    return scheduler or os.environ.get(SCHEDULER_ENV) or None


@contextmanager
def dask_client(scheduler=None, workers=None, timeout=30):
    """A ``distributed.Client``: to ``scheduler`` (or ``$MUTUAL_DASK_SCHEDULER``) if given, else to an
    embedded ``LocalCluster`` of ``workers`` single-threaded processes (default: one per core),
    closed on exit."""
    from dask.distributed import Client, LocalCluster

    address = scheduler_address(scheduler)
    if address == INLINE:
        raise ValueError(f"scheduler={INLINE!r} runs without Dask: no client")
    if workers is not None and (isinstance(workers, bool) or int(workers) != workers or workers < 1):
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    if address:
        client = Client(address, timeout=timeout)
        try:
            yield client
        finally:
            client.close()
        return
    cluster = LocalCluster(n_workers=int(workers or os.cpu_count() or 1), threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR)
    client = Client(cluster, timeout=timeout)
    try:
        yield client
    finally:
        client.close()
        cluster.close()


class TaskCache:
    """Results of finished tasks in ``folder`` (default ``<cache dir>/power``), one pickle per task,
    named by the hash of the task's parameters and ``version`` (the code that computes them)."""

    def __init__(self, version, folder=None):
        if not isinstance(version, str) or not version:
            raise ValueError(f"version must be a non-empty string, got {version!r}")
        self.version = version
        self.folder = Path(folder) if folder is not None else cache_dir() / "power"

    def __repr__(self):
        return f"TaskCache({str(self.folder)!r}, version={self.version!r})"

    def key(self, params):
        text = json.dumps({"params": params, "version": self.version}, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:32]

    def path(self, params):
        return self.folder / f"{self.key(params)}.pkl"

    def get(self, params):
        """The cached result, or None (also for an unreadable file, which is then recomputed)."""
        path = self.path(params)
        try:
            with open(path, "rb") as fh:
                return pickle.load(fh)
        except FileNotFoundError:
            return None
        except (pickle.UnpicklingError, EOFError, AttributeError, ValueError):
            return None

    def put(self, params, result):
        with atomic_path(self.path(params)) as tmp:
            with open(tmp, "wb") as fh:
                pickle.dump(result, fh, protocol=pickle.HIGHEST_PROTOCOL)


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


def _timed(fn, task, *shared):
    start = time.perf_counter()
    result = fn(task, *shared)
    return result, time.perf_counter() - start


def run_tasks(fn, tasks, params=None, shared=(), cache=None, scheduler=None, workers=None, client=None,
              progress=True, desc="tasks"):
    """``[fn(task, *shared) for task in tasks]`` on Dask (module docstring), in task order.

    ``params(task)`` gives the task's parameters as JSON-able data (default ``task.params()``), the
    cache key with ``cache.version``. ``client``: an open ``distributed.Client`` (else one is made
    from ``scheduler`` / ``workers`` for this call). Returns ``(results, SweepStats)``.
    """
    tasks = list(tasks)
    params = params or (lambda t: t.params())
    start = time.perf_counter()
    results = [cache.get(params(t)) if cache is not None else None for t in tasks]
    todo = [i for i, r in enumerate(results) if r is None]
    stats = SweepStats(tasks=len(tasks), cached=len(tasks) - len(todo), computed=len(todo))
    bar = tqdm(total=len(tasks), initial=stats.cached, desc=desc, disable=not progress or None)

    def done(i, result, seconds):
        results[i] = result
        stats.task_seconds.append(seconds)
        if cache is not None:
            cache.put(params(tasks[i]), result)
        bar.update(1)

    try:
        if todo and scheduler_address(scheduler) == INLINE and client is None:
            stats.where, stats.workers = INLINE, 1
            for i in todo:
                done(i, *_timed(fn, tasks[i], *shared))
        elif todo:
            with (_given(client) if client is not None else dask_client(scheduler, workers)) as c:
                _run_on(c, fn, tasks, todo, shared, params, cache, done, stats)
    finally:
        bar.close()
    stats.seconds = time.perf_counter() - start
    return results, stats


@contextmanager
def _given(client):
    yield client


def _run_on(client, fn, tasks, todo, shared, params, cache, done, stats):
    from dask.distributed import as_completed

    stats.where = str(client.scheduler.address)
    held = client.scatter(list(shared), broadcast=True, hash=False) if shared else []
    version = cache.version if cache is not None else "uncached"
    futures = {}
    for i in todo:
        key = hashlib.sha256(json.dumps([params(tasks[i]), version], sort_keys=True, default=str).encode()).hexdigest()
        futures[client.submit(_timed, fn, tasks[i], *held, key=f"{getattr(fn, '__name__', 'task')}-{key[:24]}",
                              pure=False)] = i
    for future in as_completed(futures):
        result, seconds = future.result()
        done(futures[future], result, seconds)
        future.release()
    info = client.scheduler_info(n_workers=-1) if _takes_n_workers(client) else client.scheduler_info()
    stats.workers = len(info["workers"])  # after the run: workers of a remote cluster may join late


def _takes_n_workers(client):
    import inspect

    return "n_workers" in inspect.signature(client.scheduler_info).parameters


def noop(task):
    """A task that does nothing (measures the per-task overhead of the machinery)."""
    return task
