"""The one Dask runner (``mutual.parallel``): results in task order whatever runs them, an embedded cluster
that accepts only its own process (another client, with no certificate or with a certificate of its own,
is refused by the scheduler and by the workers; no HTTP route, nothing on port 8787), a user's own TLS
cluster reached by address with the security of their Dask configuration, and no cluster at all when no
private one can be made."""

import asyncio
import json
import operator
import os
import subprocess
import sys
import time
import urllib.error
import urllib.request

import dask
import psutil
import pytest
from distributed import Client
from distributed.comm import connect
from distributed.security import Security

from mutual import parallel


def _square_plus(task, offset):
    return task * task + offset


@pytest.fixture(scope="module")
def private():
    with parallel.private_cluster(workers=1) as client:
        yield client


def test_results_come_back_in_task_order_inline_and_on_the_cluster(private):
    seen = []
    inline, ran = parallel.map_tasks(_square_plus, range(7), shared=(3,), scheduler="inline")
    remote, ran_remote = parallel.map_tasks(_square_plus, range(7), shared=(3,), client=private,
                                            on_result=lambda i, r: seen.append(i))
    assert inline == remote == [k * k + 3 for k in range(7)]
    assert sorted(seen) == list(range(7)) and ran.where == "inline" and ran_remote.workers == 1
    assert ran_remote.where.startswith("tls://127.0.0.1:")


def _settings(task):
    import os
    return os.environ.get("MALLOC_TRIM_THRESHOLD_"), os.environ.get("OMP_NUM_THREADS")


def test_starting_a_cluster_leaves_this_processs_environment_as_it_was(monkeypatch):
    """Dask's nanny writes its workers' settings (MALLOC_TRIM_THRESHOLD_, OMP_NUM_THREADS=1, PYTHONHASHSEED, ...)
    into the environment of the process that starts or restarts them, where every later subprocess (a kernel, a
    command) inherited them; and its MALLOC_TRIM_THRESHOLD_ turns off glibc's dynamic mmap threshold in the workers
    (every large NumPy temporary mapped afresh: an inference of the continuous benchmark ran 3.5 times slower). The
    workers keep ours (none) and run one thread each; this process's environment is as it was."""
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    monkeypatch.setenv("PYTHONHASHSEED", "0")
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    before = dict(os.environ)
    with parallel.private_cluster(workers=1) as client:
        theirs, _ = parallel.map_tasks(_settings, [0], client=client)
        assert dict(os.environ) == before
        client.restart()
        again, _ = parallel.map_tasks(_settings, [1], client=client)
    assert theirs == again == [(None, "1")] and dict(os.environ) == before


def _intruder_client(address, security):
    with Client(address, security=security, timeout=5) as intruder:
        return intruder.submit(sum, [1, 2]).result(timeout=5)


@pytest.mark.parametrize("how", ["no certificate", "a certificate of its own", "plain TCP"])
def test_another_client_cannot_connect_to_the_scheduler(private, how):
    address = private.scheduler.address
    if how == "plain TCP":
        address = address.replace("tls://", "tcp://")
    with pytest.raises(Exception):
        _intruder_client(address, Security.temporary() if how == "a certificate of its own" else None)


def test_another_process_cannot_reach_the_workers(private):
    async def knock(address):
        comm = await connect(address, timeout=5, **Security.temporary().get_connection_args("client"))
        await comm.write({"op": "identity"})
        return await comm.read()

    workers = list(private.scheduler_info()["workers"])
    assert workers and all(w.startswith("tls://127.0.0.1:") for w in workers)
    for address in workers:
        with pytest.raises(Exception):
            asyncio.run(knock(address))


def _listening(pids):
    ports = []
    for pid in pids:
        for conn in psutil.Process(pid).net_connections(kind="inet"):
            if conn.status == psutil.CONN_LISTEN:
                ports.append((conn.laddr.ip, conn.laddr.port))
    return ports


def test_nothing_listens_on_8787_and_no_http_route_answers(private):
    pids = {psutil.Process().pid, *private.run(lambda: psutil.Process().pid).values()}
    pids |= {p.pid for p in psutil.Process().children(recursive=True)}
    ports = _listening(pids)
    assert ports and all(ip == "127.0.0.1" for ip, _ in ports), ports
    assert 8787 not in {port for _, port in ports}
    comm_ports = {int(a.rsplit(":", 1)[1]) for a in [private.scheduler.address, *private.scheduler_info()["workers"]]}
    for _, port in ports:
        if port in comm_ports:
            continue
        for route in ("/status", "/info/main/workers.html", "/json/identity.json", "/health", "/metrics"):
            try:
                urllib.request.urlopen(f"http://127.0.0.1:{port}{route}", timeout=5)
                answered = True
            except urllib.error.HTTPError as err:
                answered = err.code != 404
            except (urllib.error.URLError, ConnectionError, OSError):
                answered = False        # a TLS comm port: not HTTP
            assert not answered, f"port {port} answered {route}"


def _pem_files(tmp_path):
    security = Security.temporary()
    files = {}
    for name, text in (("ca", security.tls_ca_file), ("cert", security.tls_client_cert),
                       ("key", security.tls_client_key)):
        files[name] = tmp_path / f"{name}.pem"
        files[name].write_text(text)
        files[name].chmod(0o600)
    return files


def _wait_for(path, seconds=120):
    end = time.time() + seconds
    while time.time() < end:
        try:
            return json.loads(path.read_text())["address"]
        except (OSError, ValueError, KeyError):
            time.sleep(0.2)
    raise TimeoutError(f"no scheduler file at {path}")


def test_a_users_own_tls_cluster_is_reached_with_their_dask_configuration(tmp_path):
    pem = _pem_files(tmp_path)
    tls = ["--tls-ca-file", str(pem["ca"]), "--tls-cert", str(pem["cert"]), "--tls-key", str(pem["key"])]
    file, quiet = tmp_path / "scheduler.json", dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                               "--port", "0", "--protocol", "tls", "--no-dashboard", "--scheduler-file", str(file),
                               *tls], **quiet)]
    try:
        address = _wait_for(file)
        procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nworkers",
                                       "1", "--nthreads", "1", "--no-dashboard", *tls], **quiet))
        config = {"distributed.comm.tls.ca-file": str(pem["ca"]), "distributed.comm.tls.client.cert": str(pem["cert"]),
                  "distributed.comm.tls.client.key": str(pem["key"])}
        with dask.config.set(config):
            results, ran = parallel.map_tasks(operator.add, range(4), shared=(1,), scheduler=address)
        assert results == [1, 2, 3, 4] and ran.where == address
        with pytest.raises(Exception):
            _intruder_client(address, None)          # the user's cluster keeps refusing others too
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def test_without_a_private_certificate_no_cluster_is_started(monkeypatch):
    monkeypatch.setattr(parallel, "can_be_private", lambda: False)
    monkeypatch.delenv(parallel.SCHEDULER_ENV, raising=False)
    with pytest.warns(RuntimeWarning, match="cryptography.*in this process"):
        results, ran = parallel.map_tasks(_square_plus, range(3), shared=(0,))
    assert results == [0, 1, 4] and ran.where == "inline"
    with pytest.raises(RuntimeError, match="cryptography"), parallel.private_cluster(1):
        pass


@pytest.mark.parametrize("call, message", [
    (lambda: parallel.scheduler_address(5), "scheduler must be an address string"),
    (lambda: parallel.map_tasks(_square_plus, [1], (0,), workers=0), "workers must be a positive integer"),
    (lambda: parallel.dask_client("inline").__enter__(), "runs without Dask"),
])
def test_bad_runner_arguments_are_named(call, message):
    with pytest.raises(ValueError, match=message):
        call()
