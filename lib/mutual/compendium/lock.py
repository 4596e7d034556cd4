"""One notebook runner per output folder, and disk errors in one line.

Two runners writing one output folder (say, a quick run and a run with other parameters) would mix
their outputs: one run's results beside the other's figures. A runner therefore holds the folder's
lock (:mod:`mutual.folder_lock`, the one every ``mutual`` command takes on its ``--out``) while it works
there, and a second runner on the same folder stops at once with one line naming the folder and the
run that holds it (it does not wait: a run takes minutes, and the user should choose another
``--output`` or let the first finish). What the holding run is (pid, notebooks, parameters, start
time) is written to ``running.json`` in its executed folder while it runs, for that message, and
``runs.count`` beside it counts the runs that ever took the folder: :func:`writers` tells another run
whether someone else may have written there meanwhile (see :mod:`.notebooks`).
"""

import errno
import json
import os
import time
from contextlib import contextmanager
from pathlib import Path

from ..atomic import write_text
from ..folder_lock import FolderBusy, hold
from .paths import BUILD
from .runs import shown

#: where a full run (the only one that may write figures/ and data/) says it runs, with its count of runs beside
#: it: a change to the committed files during another run is that run's own only when no full run wrote meanwhile
COMMITTED_RUN = BUILD / "executed" / "running.json"


class OutputBusy(FolderBusy):
    """Another runner is writing to the output folder; the message names the folder and that run."""


def disk_error(err, doing="write"):
    """One line for an OSError of the disk: what could not be done where, and why (ENOSPC, EROFS, ...)."""
    where = shown(err.filename) if getattr(err, "filename", None) else "the output folder"
    code = errno.errorcode.get(err.errno, "")
    reason = err.strerror or str(err)
    return f"cannot {doing} {where}: {reason}" + (f" ({code})" if code else "")


def check_output_folder(folder):
    """Create ``folder`` if needed; raise OSError (for :func:`disk_error`) when it is a file or not writable."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise NotADirectoryError(errno.ENOTDIR, "it is a file, not a folder (--output names a folder)", str(folder))
    folder.mkdir(parents=True, exist_ok=True)
    if not os.access(folder, os.W_OK | os.X_OK):
        code = errno.EROFS if _read_only(folder) else errno.EACCES
        raise PermissionError(code, os.strerror(code), str(folder))


def _read_only(folder):
    try:
        return bool(os.statvfs(folder).f_flag & os.ST_RDONLY)
    except OSError:
        return False


def _holder(info):
    try:
        run = json.loads(Path(info).read_text())
        started = time.strftime("%H:%M:%S", time.localtime(run["started"]))
        return (f"pid {run['pid']}, a {run['mode']} run of {', '.join(run['notebooks'])} with parameters "
                f"{run['parameters']}, started at {started}")
    except (OSError, ValueError, KeyError, TypeError):
        return "a run that did not say what it is"


@contextmanager
def output_lock(folder, info, mode, notebooks, parameters):
    """Hold the output ``folder`` for this run (see the module); ``info`` is where the run says what it is.
    Raises :class:`OutputBusy` when another runner holds it. Re-entrant within one process."""
    folder = Path(folder).resolve()
    busy = lambda: (f"another runner is writing to {shown(folder)} ({_holder(info)}); let it finish, or give "  # noqa: E731
                    "this run another --output")
    try:
        with hold(folder, busy):
            _count(info)
            write_text(info, json.dumps({"pid": os.getpid(), "mode": mode, "notebooks": [Path(n).name for n in notebooks],
                                         "parameters": parameters, "started": time.time()}))
            try:
                yield
            finally:
                try:
                    Path(info).unlink(missing_ok=True)
                except OSError:
                    pass
    except FolderBusy as err:
        if isinstance(err, OutputBusy):
            raise
        raise OutputBusy(str(err)) from None


def _count(info):
    path = Path(info).with_name("runs.count")
    try:
        runs = int(path.read_text())
    except (OSError, ValueError):
        runs = 0
    write_text(path, f"{runs + 1}\n")


def writers(info):
    """A token of the runs that took the folder whose runner writes ``info``: how many ever did, and the pid of
    the one that holds it now (None). Equal tokens before and after a span of time: no such run wrote there."""
    try:
        runs = Path(info).with_name("runs.count").read_text().strip()
    except OSError:
        runs = "0"
    try:
        pid = json.loads(Path(info).read_text())["pid"]
        os.kill(pid, 0)
    except (OSError, ValueError, KeyError, TypeError):
        pid = None
    return runs, pid
