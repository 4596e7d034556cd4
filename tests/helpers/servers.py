"""Servers a test starts (JupyterLab, the book's static server): a free port, and the wait for the first answer."""

import contextlib
import socket
import time
import urllib.request

import pytest


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for_http(url, process, what, timeout=120):
    """Wait until ``url`` answers; fail, naming ``what``, if ``process`` exits first or ``timeout`` s pass.
    (jupyter_server even opens the browser before its event loop binds the port.)"""
    deadline = time.time() + timeout
    while time.time() < deadline:
        if process.poll() is not None:
            pytest.fail(f"{what} exited with status {process.returncode} before answering on {url}", pytrace=False)
        with contextlib.suppress(OSError):
            with urllib.request.urlopen(url, timeout=5):
                return
        time.sleep(0.5)
    pytest.fail(f"{what} did not answer on {url} within {timeout} s", pytrace=False)
