"""What every ``mutual`` command shares: the output options (``--out``, ``--json``,
``--no-progress``), CSV input read as the user wrote it (:func:`read_csv`), outputs written as a
set (:func:`output_set`: all of a run's files or none), one-line error reports with exit status 2
for bad input, and progress bars on stderr.

Only the standard library is imported at module level, so that ``mutual --help`` stays fast;
numpy, pandas and matplotlib are imported inside the functions that need them.
"""

import argparse
import json
import math
import os
import re
import sys
import warnings
from contextlib import contextmanager
from functools import partial
from pathlib import Path

from .. import budget

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_TERMINATED = 0, 1, 2, 130, 143


class InputError(Exception):
    """Bad input (a file, a column, an option): reported as one line, exit status 2."""


class OutputError(Exception):
    """The outputs could not be written (a full disk, say); nothing was left in --out: one line, exit status 1."""


#: an option value that starts with '-' but is a number or a list of numbers: -1, -0.5, -1e-3, -inf, -1,1
_NEGATIVE_VALUE = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?(,.*)?$|^-(inf|infinity|nan)(,.*)?$", re.I)


class Parser(argparse.ArgumentParser):
    """argparse's parser for every ``mutual`` command: an option's value that starts with '-' and reads as a
    number or a comma-separated list of numbers (``--w-max -1,1``, ``--rho -0.5``) is a value, not an option;
    for any other value that starts with '-' the error says to write ``--option=VALUE``."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = _NEGATIVE_VALUE

    def error(self, message):
        option = re.match(r"argument (--[\w-]+)(/-\w)?: expected one argument", message)
        if option:
            message += f" (a value that starts with '-' is written {option.group(1)}=VALUE)"
        super().error(message)


def command_group(subparsers, name, help, description):
    """Add the group ``mutual NAME`` and return its commands (one of which must be given)."""
    group = subparsers.add_parser(name, help=help, description=description)
    return group.add_subparsers(title="commands", dest="command", metavar="COMMAND", required=True)


def add_command(commands, name, help, description, example):
    """Add a command to a group: ``description`` and ``example`` shown in ``--help`` as they are written."""
    return commands.add_parser(name, help=help, description=description, epilog=example,
                               formatter_class=argparse.RawDescriptionHelpFormatter)


def add_output_options(parser):
    """``--out DIR``, ``--json`` and ``--no-progress`` on a command's parser."""
    group = parser.add_argument_group("output")
    group.add_argument("--out", metavar="DIR", type=Path, default=Path("."),
                       help="folder for the output files, created if missing (default: the current directory); "
                            "the files are written as a set, so a failed or interrupted run leaves none of them")
    group.add_argument("--json", action="store_true",
                       help="print the results as one JSON object on stdout instead of the readable summary")
    group.add_argument("--no-progress", action="store_true", help="no progress bars on stderr")
    size = parser.add_argument_group("size")
    size.add_argument("--allow-large", action="store_true",
                      help="go ahead even when the work is estimated to need more memory than is available, or more "
                           f"than ${budget.MINUTES_ENV} minutes (default {budget.MINUTES}); without it such a request "
                           "is refused before it starts, with the estimate")


_INPUTS = []   # the input files of the running command (an output set never replaces one)


def existing_file(path):
    """``path`` as a Path, or an InputError if it names no readable file; remembered as an input of the run."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if not path.is_file():
        raise InputError(f"{path}: not a file")
    _INPUTS.append(path)
    return path


@contextmanager
def about(path):
    """Turn a ValueError (or a KeyError, TypeError) raised while reading or analysing ``path`` into an
    :class:`InputError` whose message starts with the file name."""
    try:
        yield
    except (InputError, budget.TooLarge):
        raise
    except (ValueError, KeyError, TypeError) as err:
        message = _first_line(err)
        raise InputError(message if str(path) in message else f"{path}: {message}") from None


def read_csv(path, columns=None, keep=None):
    """The CSV table at ``path`` with every cell as text as written, each row with its line in the file
    (:func:`mutual.inputs.read_csv`: ``01``, ``1``, ``NA`` and ``None`` are distinct names; only empty cells
    are missing; a repeated column name, another delimiter or a row with more fields than the header is
    refused), ``columns`` required, only ``keep`` kept (all without it), with the errors of :func:`about`
    (file named, one line)."""
    from ..inputs import read_csv as read_table
    with about(path):
        return read_table(path, columns, keep)


def numeric_column(frame, column, path):
    """The column as floats, or an InputError naming the file, the line and the column
    (:func:`mutual.inputs.number_column`; numbers that differ only beyond a double's digits are refused too)."""
    from ..inputs import number_column
    with about(path):
        return number_column(frame, column, distinct=True)


def check_out(args):
    """Refuse an ``--out`` that exists and is not a folder, or is a link that leads nowhere (before any work)."""
    out = getattr(args, "out", None)
    if out is None:
        return
    out = Path(out)
    if out.is_symlink() and not out.exists():
        raise InputError(f"--out {out}: a symbolic link that leads to no folder ({_link_target(out)}); remove it or "
                         "point it at a folder")
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: exists and is not a folder")


def _link_target(link):
    try:
        return f"it points to {os.readlink(link)}, which does not exist or loops back"
    except OSError as err:
        return err.strerror or str(err)


STAGING = ".mutual-partial-"      # the hidden folder inside --out where a run's files wait for the commit


class OutputSet:
    """The files of one run, written into a temporary folder (see :func:`output_set`)."""

    def __init__(self, out, staging, inputs=()):
        self.out, self.staging, self.names = Path(out), Path(staging), []
        self.inputs = list(inputs)

    def path(self, name):
        """Where to write the output ``name`` now; returns the staging path (the file lands in --out on success).
        Raises InputError when the output would replace one of the run's input files."""
        if Path(name).name != name or name.startswith("."):
            raise ValueError(f"an output name must be a plain file name, got {name!r}")
        if name in self.names:
            raise ValueError(f"output {name!r} written twice")
        final = self.final(name)
        for source in self.inputs:
            if final.exists() and source.exists() and os.path.samefile(final, source):
                raise InputError(f"--out {self.out}: the output {name} would replace the input {source}; choose "
                                 "another --out (nothing was written)")
        self.names.append(name)
        return self.staging / name

    def final(self, name):
        return self.out / name

    def csv(self, frame, name):
        """Write a DataFrame; numbers read back exactly (:func:`mutual.inputs.format_exact`). Returns its final path."""
        from ..inputs import format_exact
        frame.to_csv(self.path(name), index=False, float_format=format_exact)
        return self.final(name)

    def figure(self, fig, name):
        """Save a matplotlib figure (PNG, 150 dpi, no timestamp) and close it. Returns its final path."""
        import matplotlib.pyplot as plt
        try:
            fig.savefig(self.path(name), dpi=150, bbox_inches="tight", metadata={"Software": None})
        finally:
            plt.close(fig)
        return self.final(name)


@contextmanager
def output_set(args):
    """Write a command's outputs as a set: ``with output_set(args) as files: files.csv(table, "a.csv"); ...``.

    The run holds ``--out``'s lock (:mod:`mutual.folder_lock`, the notebook runner's too) from the first file
    to the last, so a second run into the same folder stops at once instead of mixing its files with these.
    The files go into a hidden staging folder inside ``--out`` and are renamed into it when all are written,
    so a run that fails while writing (a full disk, an error in a figure, Ctrl-C, SIGTERM) leaves none of its
    outputs, and a run that succeeds leaves all of them; a staging folder that a killed run left behind is
    removed by the next run into that folder. An ``--out`` this run created is removed again when it stays
    empty. An output never replaces one of the run's input files. A write that fails raises
    :class:`OutputError` naming ``--out``.
    """
    import shutil
    import tempfile
    from ..folder_lock import FolderBusy, hold
    out = Path(args.out)
    check_out(args)
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"--out {out}: cannot write there ({err.strerror or err})") from None
    done = False
    try:
        with hold(out, lambda: f"--out {out}: another run is writing its outputs there now; let it finish, or "
                               "choose another --out"):
            for stale in out.glob(f"{STAGING}*"):     # left by a run killed while writing (we hold the folder)
                shutil.rmtree(stale, ignore_errors=True)
            try:
                staging = Path(tempfile.mkdtemp(prefix=STAGING, dir=out))
            except OSError as err:
                raise InputError(f"--out {out}: cannot write there ({err.strerror or err})") from None
            files = OutputSet(out, staging, _INPUTS)
            try:
                try:
                    yield files
                except OSError as err:
                    raise OutputError(f"--out {out}: could not write {Path(err.filename or '').name or 'the outputs'} "
                                      f"({err.strerror or err}); no output was left") from None
                _commit(files)
                done = True
            finally:
                shutil.rmtree(staging, ignore_errors=True)
    except FolderBusy as err:
        raise InputError(str(err)) from None
    finally:
        if created and not done:
            try:
                out.rmdir()                         # only when empty: what another run put there stays
            except OSError:
                pass


def _commit(files):
    """Move the staged files into --out, one rename each (the folder is held, so no other run interleaves)."""
    out, staging = files.out, files.staging
    clash = [n for n in files.names if (out / n).is_dir()]
    if clash:
        raise OutputError(f"--out {out}: {clash[0]!r} is a folder there; no output was written")
    for name in files.names:
        os.chmod(staging / name, 0o644)
        os.replace(staging / name, out / name)


def use_agg():
    """The non-interactive matplotlib backend and the compendium's plot style."""
    import matplotlib
    matplotlib.use("Agg")
    from ..style import use_style
    use_style()


def progress(args, **kwargs):
    """A tqdm progress bar on stderr (none with ``--no-progress``)."""
    from tqdm import tqdm
    return tqdm(file=sys.stderr, disable=bool(getattr(args, "no_progress", False)), **kwargs)


def jsonable(value):
    """Plain JSON types for numpy scalars/arrays, tuples and paths; NaN and infinities become null."""
    import numpy as np
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, Path):
        return str(value)
    return value


def report(args, summary, results):
    """Print the readable ``summary`` (a string), or with ``--json`` the ``results`` as one JSON object."""
    if args.json:
        print(json.dumps(jsonable(results), indent=2, allow_nan=False))
    else:
        print(summary.rstrip("\n"))


def run(args, prog):
    """Run ``args.handler(args)``; report bad input in one line (exit 2), never a traceback.

    Every command runs within the limits of :mod:`mutual.budget` (``$MUTUAL_MAX_MINUTES`` and the memory
    available; ``--allow-large`` lifts them): a request estimated beyond them is refused before it starts.
    Set ``MUTUAL_DEBUG=1`` to see the traceback of an unexpected error.
    """
    _INPUTS.clear()
    restore = _terminate_cleanly()
    try:
        check_out(args)
        try:
            minutes = budget.command_line_minutes()
        except ValueError as err:
            raise InputError(str(err)) from None
        say = partial(print, f"{prog}:", file=sys.stderr)     # a large request's estimate, before it starts
        with budget.limits(minutes, getattr(args, "allow_large", False), "--allow-large", say), \
                warnings.catch_warnings():
            warnings.showwarning = _show_warning(prog)
            args.handler(args)
        return EXIT_OK
    except budget.TooLarge as err:
        return _fail(prog, str(err), EXIT_BAD_INPUT)
    except MemoryError as err:        # what the estimate missed: one line, never a traceback
        detail = f" ({_first_line(err)})" if str(err) else ""
        return _fail(prog, f"ran out of memory{detail}; ask for less (fewer cells, steps, levels or demonstrations)",
                     EXIT_FAILED)
    except InputError as err:
        return _fail(prog, str(err), EXIT_BAD_INPUT)
    except OutputError as err:
        return _fail(prog, str(err), EXIT_FAILED)
    except (FileNotFoundError, IsADirectoryError, PermissionError) as err:
        where = f"{err.filename}: " if err.filename else ""
        return _fail(prog, f"{where}{err.strerror or err}", EXIT_BAD_INPUT)
    except KeyboardInterrupt:
        return _fail(prog, "interrupted", EXIT_INTERRUPTED)
    except Terminated:
        return _fail(prog, "terminated (SIGTERM); no output of this run was left", EXIT_TERMINATED)
    except BrokenPipeError:           # the reader of stdout left (| head): the outputs are written; say nothing
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except Exception as err:  # an unexpected failure: one line unless asked for the traceback
        if os.environ.get("MUTUAL_DEBUG"):
            raise
        return _fail(prog, f"{type(err).__name__}: {_first_line(err)} (set MUTUAL_DEBUG=1 for the traceback)",
                     EXIT_FAILED)
    finally:
        restore()


class Terminated(BaseException):
    """SIGTERM arrived: raised where the command is, so that its output set cleans up as for Ctrl-C."""


def _terminate_cleanly():
    """Turn SIGTERM into :class:`Terminated` while a command runs (main thread only); returns the undo."""
    import signal
    import threading
    if threading.current_thread() is not threading.main_thread():
        return lambda: None

    def terminated(signum, frame):
        raise Terminated()

    previous = signal.signal(signal.SIGTERM, terminated)
    return lambda: signal.signal(signal.SIGTERM, previous)


def _show_warning(prog):
    """Warnings about the input (:class:`mutual.inputs.InputWarning`) and the caches
    (:class:`mutual.cache.CacheWarning`) as one line ``PROG: warning: ...`` on stderr."""
    def show(message, category, filename, lineno, file=None, line=None):
        if category.__name__ in ("InputWarning", "CacheWarning"):
            print(f"{prog}: warning: {message}", file=sys.stderr)
        else:
            print(warnings.formatwarning(message, category, filename, lineno, line).rstrip(), file=sys.stderr)
    return show


def _fail(prog, message, status):
    print(f"{prog}: error: {message}", file=sys.stderr)
    return status


def _first_line(err):
    text = str(err).strip() or type(err).__name__
    return " ".join(text.split())
