"""Running independent tasks on Dask, as the power planner does (``mutual.study.sweep``), without its
study-specific machinery (or its imports: no jax here).

:func:`map_tasks` runs ``fn(task, *shared)`` for every task on a ``dask.distributed`` cluster -- the
scheduler at ``scheduler`` or ``$MUTUAL_DASK_SCHEDULER``, else an embedded ``LocalCluster`` of
``workers`` single-threaded processes (default one per core) -- sends the ``shared`` inputs once to
every worker, and returns the results in task order, so they do not depend on the number of workers
or the order they finish in.
"""

import logging
import os

SCHEDULER_ENV = "MUTUAL_DASK_SCHEDULER"


def map_tasks(fn, tasks, shared=(), scheduler=None, workers=None, progress=False, desc="tasks"):
    """``[fn(task, *shared) for task in tasks]`` on Dask (module docstring)."""
    from dask.distributed import Client, LocalCluster, as_completed
    from tqdm.auto import tqdm

    if workers is not None and (isinstance(workers, bool) or int(workers) != workers or workers < 1):
        raise ValueError(f"workers: must be a positive integer, got {workers!r}")
    address = scheduler or os.environ.get(SCHEDULER_ENV) or None
    cluster = None if address else LocalCluster(n_workers=int(workers or os.cpu_count() or 1), threads_per_worker=1,
                                                processes=True, dashboard_address=None, silence_logs=logging.ERROR)
    client = Client(address or cluster, timeout=30)
    results = [None] * len(tasks)
    try:
        held = client.scatter(list(shared), broadcast=True, hash=False) if shared else []
        futures = {client.submit(fn, task, *held, pure=False): i for i, task in enumerate(tasks)}
        with tqdm(total=len(tasks), desc=desc, disable=not progress) as bar:
            for future in as_completed(futures):
                results[futures[future]] = future.result()
                future.release()
                bar.update(1)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return results
