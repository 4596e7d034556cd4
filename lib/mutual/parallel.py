"""Independent tasks on Dask: the one runner of the power sweep (:mod:`mutual.study.sweep`) and of the
discretization of continuous systems (:mod:`mutual.constraints.continuous.discretization`).

:func:`map_tasks` runs ``fn(task, *shared)`` for every task, sends the ``shared`` inputs once to every
worker, hands each result to ``on_result(i, result)`` as it arrives, and returns the results in task
order, so they never depend on the number of workers or the order they finish in. Where (``scheduler``):

* ``None`` (the default): the cluster at ``$MUTUAL_DASK_SCHEDULER`` if set, else an embedded private
  cluster (:func:`private_cluster`): ``workers`` single-threaded worker processes (default one per core)
  on 127.0.0.1 that accept only this process. Every connection is TLS with a throwaway certificate made
  for this run (``distributed.security.Security.temporary()``, held in memory): a client or worker without
  it cannot connect, so no other local user can run code in its workers. Its HTTP servers listen on
  random loopback ports and serve no route: no dashboard, no status page, nothing on port 8787. Without
  the ``cryptography`` package, which makes the certificate, no cluster is started: the tasks run in this
  process (one warning says so);
* an address (``"tls://host:8786"``, ``"tcp://..."``): a user's own running cluster, with the security
  settings of their Dask configuration (``distributed.comm.tls.*``), as ``dask`` itself reads them;
* ``"inline"``: in this process, without Dask (a reference, and for debugging).

Nothing heavy is imported until a cluster is needed.
"""

import hashlib
import json
import logging
import os
import warnings
from contextlib import contextmanager
from dataclasses import dataclass

SCHEDULER_ENV = "MUTUAL_DASK_SCHEDULER"
INLINE = "inline"
#: no HTTP route on the embedded cluster's scheduler and workers: no dashboard, no status or metrics page
NO_ROUTES = {"distributed.scheduler.http.routes": [], "distributed.worker.http.routes": []}
#: the embedded workers allocate as this process does: Dask's nanny sets MALLOC_TRIM_THRESHOLD_ in each worker, which
#: turns off glibc's dynamic mmap threshold, so every large NumPy temporary is mapped and its pages faulted in afresh (a
#: NumPy-heavy task, such as an inference of the continuous benchmark, ran 3.5 times slower); an exported value stays
PRE_SPAWN = "distributed.nanny.pre-spawn-environ"
KEEP_MALLOC = {f"{PRE_SPAWN}.MALLOC_TRIM_THRESHOLD_": None}
#: one thread per worker process, whatever this process's own setting (the nanny would pass that on instead)
ONE_THREAD = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")
#: what a nanny writes into the environment of the process that starts its workers, besides its pre-spawn settings
NANNY_WRITES = ("PYTHONHASHSEED", "__DASK_PARENT_PID")


@dataclass(frozen=True)
class Ran:
    """Where tasks ran: ``where`` ("inline" or the scheduler's address) and how many ``workers`` it had."""
    where: str
    workers: int


def scheduler_address(scheduler=None):
    """The scheduler to use: ``scheduler`` if given, else ``$MUTUAL_DASK_SCHEDULER``, else None (the
    embedded private cluster)."""
    if scheduler is not None and not isinstance(scheduler, str):
        raise ValueError(f"scheduler must be an address string or {INLINE!r}, got {scheduler!r}")
    return scheduler or os.environ.get(SCHEDULER_ENV) or None


def _check_workers(workers):
    if workers is not None and (isinstance(workers, bool) or int(workers) != workers or workers < 1):
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    return int(workers or os.cpu_count() or 1)


def can_be_private():
    """Whether an embedded cluster can be made private: ``cryptography`` makes its throwaway certificate."""
    try:
        import cryptography  # noqa: F401
    except ImportError:
        return False
    return True


@contextmanager
def _environ_kept(names, during=None):
    """This process's environment variables ``names`` as they were afterwards, and ``during`` (a dict) meanwhile: a
    nanny writes its workers' variables into the process that starts (or restarts) them, where every later
    subprocess would inherit them. (Another thread's subprocess started meanwhile still may.)"""
    before = {name: os.environ.get(name) for name in names}
    os.environ.update(during or {})
    try:
        yield
    finally:
        for name, value in before.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


@contextmanager
def private_cluster(workers=None, timeout=30):
    """A ``distributed.Client`` of an embedded cluster that accepts only this process (module docstring),
    closed on exit."""
    import dask
    from dask.distributed import Client, LocalCluster

    from distributed.security import Security

    n = _check_workers(workers)
    if not can_be_private():
        raise RuntimeError("an embedded Dask cluster needs the 'cryptography' package for its private TLS certificate; "
                           "install it, or run inline or on a scheduler of your own")
    security = Security.temporary()                 # every role, in memory only; passed to the workers by pipe
    written = {*dask.config.get(PRE_SPAWN), *ONE_THREAD, *NANNY_WRITES}
    with dask.config.set(NO_ROUTES | KEEP_MALLOC), _environ_kept(written, dict.fromkeys(ONE_THREAD, "1")):
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                               protocol="tls://", security=security, dashboard_address=None,
                               scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
                               worker_dashboard_address=None, silence_logs=logging.ERROR)
    try:
        with _environ_kept(written), Client(cluster, security=security, timeout=timeout) as client:
            yield client                            # (a restarted worker's nanny writes them again)
    finally:
        cluster.close()


@contextmanager
def dask_client(scheduler=None, workers=None, timeout=30):
    """A ``distributed.Client``: to ``scheduler`` (or ``$MUTUAL_DASK_SCHEDULER``) with the security of the
    user's Dask configuration, else to an embedded :func:`private_cluster` of ``workers`` processes; closed on exit."""
    address = scheduler_address(scheduler)
    if address == INLINE:
        raise ValueError(f"scheduler={INLINE!r} runs without Dask: no client")
    _check_workers(workers)
    if not address:
        with private_cluster(workers, timeout) as client:
            yield client
        return
    from dask.distributed import Client
    with Client(address, timeout=timeout) as client:
        yield client


def _given(client):
    @contextmanager
    def hold():
        yield client
    return hold()


def map_tasks(fn, tasks, shared=(), scheduler=None, workers=None, client=None, on_result=None, keys=None):
    """``[fn(task, *shared) for task in tasks]`` where ``scheduler`` says (module docstring); ``client``: an
    open ``distributed.Client`` to use instead. ``on_result(i, result)`` is called as each task finishes;
    ``keys(task)`` names a task's Dask key (default: a hash of the task). Returns ``(results, Ran)``."""
    tasks = list(tasks)
    results = [None] * len(tasks)
    notify = on_result or (lambda i, result: None)
    if client is None and scheduler_address(scheduler) is None and not can_be_private():
        warnings.warn("the 'cryptography' package is missing, so no private Dask cluster can be started: running the "
                      "tasks in this process (install cryptography, or give a scheduler of your own)", RuntimeWarning,
                      stacklevel=2)
        scheduler = INLINE
    if client is None and scheduler_address(scheduler) == INLINE:
        for i, task in enumerate(tasks):
            results[i] = fn(task, *shared)
            notify(i, results[i])
        return results, Ran(INLINE, 1)
    if not tasks:
        return results, Ran("", 0)
    with (_given(client) if client is not None else dask_client(scheduler, workers)) as c:
        return _run_on(c, fn, tasks, shared, notify, keys or _key, results)


def _key(task):
    text = json.dumps(task.params() if hasattr(task, "params") else repr(task), sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def _run_on(client, fn, tasks, shared, notify, keys, results):
    from dask.distributed import as_completed

    held = client.scatter(list(shared), broadcast=True, hash=False) if shared else []
    name = getattr(fn, "__name__", "task")
    futures = {client.submit(fn, task, *held, key=f"{name}-{keys(task)}-{i}", pure=False): i
               for i, task in enumerate(tasks)}
    for future in as_completed(futures):
        i = futures[future]
        results[i] = future.result()
        future.release()
        notify(i, results[i])
    info = client.scheduler_info(n_workers=-1) if _takes_n_workers(client) else client.scheduler_info()
    return results, Ran(str(client.scheduler.address), len(info["workers"]))  # after: remote workers join late


def _takes_n_workers(client):
    import inspect

    return "n_workers" in inspect.signature(client.scheduler_info).parameters
