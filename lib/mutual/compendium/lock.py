"""One notebook runner per output folder, and disk errors in one line.

Two runners writing one output folder (say, a quick run and a run with other parameters) would mix
their outputs: one run's results beside the other's figures. A runner therefore holds an exclusive
``flock`` on the output folder itself while it works there, and a second runner on the same folder
stops at once with one line naming the folder and the run that holds it (it does not wait: a run
takes minutes, and the user should choose another ``--output`` or let the first finish). The lock
belongs to the process: it is released when the runner ends, however it ends (even ``kill -9``),
so a crashed run never blocks the next one. What the holding run is (pid, notebooks, parameters,
start time) is written to ``running.json`` in its executed folder while it runs, for that message.
"""

import errno
import fcntl
import json
import os
import time
from contextlib import contextmanager
from pathlib import Path

from ..atomic import write_text
from .runs import shown

_HELD = {}   # resolved output folder -> open descriptor holding its lock (re-entrant within a process)


class OutputBusy(RuntimeError):
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
    if folder in _HELD:
        yield
        return
    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise OutputBusy(f"another runner is writing to {shown(folder)} ({_holder(info)}); let it finish, or give "
                         "this run another --output") from None
    _HELD[folder] = fd
    try:
        write_text(info, json.dumps({"pid": os.getpid(), "mode": mode, "notebooks": [Path(n).name for n in notebooks],
                                     "parameters": parameters, "started": time.time()}))
        yield
    finally:
        try:
            Path(info).unlink(missing_ok=True)
        except OSError:
            pass
        del _HELD[folder]
        os.close(fd)
