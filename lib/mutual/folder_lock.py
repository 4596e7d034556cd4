"""One writer per output folder: the lock that every command writing a set of outputs takes (the ``mutual``
commands' ``--out``, the notebook runner's output folder), so two runs into one folder never mix their files.

:func:`hold` takes an exclusive ``flock`` on the folder itself and keeps it while the run writes there; a
second run on the same folder stops at once with :class:`FolderBusy` (it does not wait: the user should
let the first finish or choose another folder). The lock belongs to the process: the kernel releases it
however the process ends (even ``kill -9``), so a crashed run never blocks the next. Re-entrant within
one process. Standard library only (the command line imports it on every run).
"""

import fcntl
import os
from contextlib import contextmanager
from pathlib import Path

_HELD = {}   # resolved folder -> open descriptor holding its lock


class FolderBusy(RuntimeError):
    """Another run holds the folder; the message says which folder (and, where known, which run)."""


@contextmanager
def hold(folder, busy_message):
    """Hold the existing ``folder`` for this run; ``busy_message()`` is the text of :class:`FolderBusy` raised
    when another process holds it."""
    folder = Path(folder).resolve()
    if folder in _HELD:
        yield
        return
    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise FolderBusy(busy_message()) from None
    _HELD[folder] = fd
    try:
        yield
    finally:
        del _HELD[folder]
        os.close(fd)
