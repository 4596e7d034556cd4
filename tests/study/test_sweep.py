"""The SIMULATED cohort sweep on Dask: identical results inline, on an embedded LocalCluster of 2 workers and
on a scheduler with a worker started as separate processes and reached by address; a cache that resumes an
interrupted sweep; bad inputs (a table)."""

import json
import subprocess
import sys
import time

import pytest

from mutual.cache import CacheWarning
from mutual.study import cohort_power as cp, sweep

from helpers.study import assert_same_cohorts


def test_local_cluster_with_two_workers_gives_the_same_results(library, tasks, inline):
    results, stats = sweep.run_tasks(cp.simulate_cohort, tasks, shared=library, workers=2, progress=False)
    assert stats.workers == 2 and stats.computed == 4
    assert_same_cohorts(results, inline)


def _wait_for(path, seconds=120):
    end = time.time() + seconds
    while time.time() < end:
        if path.exists() and path.stat().st_size > 0:
            try:
                return json.loads(path.read_text())["address"]
            except (json.JSONDecodeError, KeyError):
                pass
        time.sleep(0.2)
    raise TimeoutError(f"no scheduler file at {path}")


@pytest.fixture
def scheduler_by_address(tmp_path):
    """A scheduler and one worker started as separate processes, reached by address."""
    file = tmp_path / "scheduler.json"
    quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                               "--port", "0", "--no-dashboard", "--scheduler-file", str(file)], **quiet)]
    try:
        address = _wait_for(file)
        procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nworkers", "1",
                                       "--nthreads", "1", "--no-dashboard"], **quiet))
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def test_scheduler_by_address_gives_the_same_results(library, tasks, inline, scheduler_by_address, monkeypatch):
    monkeypatch.setenv(sweep.SCHEDULER_ENV, scheduler_by_address)
    results, stats = sweep.run_tasks(cp.simulate_cohort, tasks, shared=library, progress=False)
    assert stats.where == scheduler_by_address and stats.workers == 1
    assert_same_cohorts(results, inline)


def test_the_cache_resumes_an_interrupted_sweep(library, tasks, inline, tmp_path):
    cache = sweep.TaskCache("v1", tmp_path / "cache")
    for t, r in zip(tasks[:2], inline[:2]):  # a sweep stopped after two cohorts
        cache.put(t.params(), r)
    results, stats = sweep.run_tasks(cp.simulate_cohort, tasks, shared=library, cache=cache, scheduler="inline",
                                     progress=False)
    assert (stats.cached, stats.computed) == (2, 2)
    assert_same_cohorts(results, inline)
    cache.path(tasks[3].params()).write_bytes(b'{"format": 1, "key": ')  # a torn file is recomputed
    with pytest.warns(CacheWarning, match="does not verify"):
        results, stats = sweep.run_tasks(cp.simulate_cohort, tasks, shared=library, cache=cache, scheduler="inline",
                                         progress=False)
    assert (stats.cached, stats.computed) == (3, 1)
    assert_same_cohorts(results, inline)
    assert not [p for p in (tmp_path / "cache").iterdir() if p.name.startswith(".")], "temporary files left behind"
    assert sweep.TaskCache("v2", tmp_path / "cache").get(tasks[0].params()) is None  # new code: recomputed


def _enter(manager):
    return manager.__enter__()


CASES = [
    (sweep.TaskCache, ("",), {}, "version must be a non-empty string"),
    (sweep.scheduler_address, (5,), {}, "scheduler must be an address string"),
    (lambda: _enter(sweep.dask_client(workers=0)), (), {}, "workers must be a positive integer"),
    (lambda: _enter(sweep.dask_client(scheduler="inline")), (), {}, "runs without Dask"),
]


@pytest.mark.parametrize("fn, args, kwargs, phrase", CASES,
                         ids=[f"{getattr(c[0], '__name__', 'call')}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, phrase):
    with pytest.raises(ValueError) as err:
        fn(*args, **kwargs)
    assert phrase in str(err.value), f"{err.value!s} does not say {phrase!r}"
