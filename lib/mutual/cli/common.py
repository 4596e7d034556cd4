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
from pathlib import Path

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


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


def add_output_options(parser):
    """``--out DIR``, ``--json`` and ``--no-progress`` on a command's parser."""
    group = parser.add_argument_group("output")
    group.add_argument("--out", metavar="DIR", type=Path, default=Path("."),
                       help="folder for the output files, created if missing (default: the current directory); "
                            "the files are written as a set, so a failed or interrupted run leaves none of them")
    group.add_argument("--json", action="store_true",
                       help="print the results as one JSON object on stdout instead of the readable summary")
    group.add_argument("--no-progress", action="store_true", help="no progress bars on stderr")


def existing_file(path):
    """``path`` as a Path, or an InputError if it names no readable file."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if not path.is_file():
        raise InputError(f"{path}: not a file")
    return path


@contextmanager
def about(path):
    """Turn a ValueError (or a KeyError, TypeError) raised while reading or analysing ``path`` into an
    :class:`InputError` whose message starts with the file name."""
    try:
        yield
    except InputError:
        raise
    except (ValueError, KeyError, TypeError) as err:
        message = _first_line(err)
        raise InputError(message if str(path) in message else f"{path}: {message}") from None


def read_csv(path, columns=None):
    """The CSV table at ``path`` with every cell as text as written, each row with its line in the file
    (:func:`mutual.inputs.read_csv`: ``01``, ``1``, ``NA`` and ``None`` are distinct names; only empty cells
    are missing; a repeated column name, another delimiter or a row with more fields than the header is
    refused), ``columns`` required, with the errors of :func:`about` (file named, one line)."""
    from ..inputs import read_csv as read_table
    with about(path):
        return read_table(path, columns)


def numeric_column(frame, column, path):
    """The column as floats, or an InputError naming the file, the line and the column
    (:func:`mutual.inputs.number_column`; numbers that differ only beyond a double's digits are refused too)."""
    from ..inputs import number_column
    with about(path):
        return number_column(frame, column, distinct=True)


def output_path(args, name):
    """``args.out / name``, refusing an ``--out`` that is a file (one file at a time: prefer :func:`output_set`)."""
    check_out(args)
    return Path(args.out) / name


def write_csv(frame, path, **to_csv):
    """Write a DataFrame atomically, numbers exactly unless ``float_format`` says otherwise (one file at a
    time: prefer :func:`output_set`)."""
    from ..atomic import atomic_path
    from ..inputs import format_exact
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False, **{"float_format": format_exact, **to_csv})
    return Path(path)


def save_figure(fig, path):
    """Save a matplotlib figure atomically (PNG, 150 dpi) and close it (one file at a time: prefer :func:`output_set`)."""
    import matplotlib.pyplot as plt
    from ..atomic import atomic_path
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=150, bbox_inches="tight", metadata={"Software": None})
    plt.close(fig)
    return Path(path)


def check_out(args):
    """Refuse an ``--out`` that exists and is not a folder (before any work is done)."""
    out = getattr(args, "out", None)
    if out is not None and Path(out).exists() and not Path(out).is_dir():
        raise InputError(f"--out {out}: exists and is not a folder")


class OutputSet:
    """The files of one run, written into a temporary folder (see :func:`output_set`)."""

    def __init__(self, out, staging):
        self.out, self.staging, self.names = Path(out), Path(staging), []

    def path(self, name):
        """Where to write the output ``name`` now; returns the staging path (the file lands in --out on success)."""
        if Path(name).name != name or name.startswith("."):
            raise ValueError(f"an output name must be a plain file name, got {name!r}")
        if name in self.names:
            raise ValueError(f"output {name!r} written twice")
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

    The files go into a hidden temporary folder -- next to ``--out`` when it does not exist yet (then
    renamed to it), else inside it (then each file is renamed into ``--out``) -- so a run that fails
    while writing (a full disk, an error in a figure, Ctrl-C) leaves none of its outputs, and a run that
    succeeds leaves all of them. A write that fails raises :class:`OutputError` naming ``--out``.
    """
    import shutil
    import tempfile
    out = Path(args.out)
    check_out(args)
    fresh = not out.exists()
    try:
        (out.parent if fresh else out).mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{out.name or 'out'}.partial-", dir=out.parent if fresh else out))
    except OSError as err:
        raise InputError(f"--out {out}: cannot write there ({err.strerror or err})") from None
    files = OutputSet(out, staging)
    try:
        try:
            yield files
        except OSError as err:
            raise OutputError(f"--out {out}: could not write {Path(err.filename or '').name or 'the outputs'} "
                              f"({err.strerror or err}); no output was left") from None
        _commit(files, fresh)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _commit(files, fresh):
    """Move the staged files into --out: one rename of the folder, or one rename per file."""
    out, staging = files.out, files.staging
    if fresh:
        try:
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(staging, 0o777 & ~umask)        # a folder as mkdir makes it, not mkdtemp's 0700
            os.rename(staging, out)
            return
        except OSError:
            out.mkdir(parents=True, exist_ok=True)   # --out appeared meanwhile: move file by file
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

    Set ``MUTUAL_DEBUG=1`` to see the traceback of an unexpected error.
    """
    try:
        check_out(args)
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning(prog)
            args.handler(args)
        return EXIT_OK
    except InputError as err:
        return _fail(prog, str(err), EXIT_BAD_INPUT)
    except OutputError as err:
        return _fail(prog, str(err), EXIT_FAILED)
    except (FileNotFoundError, IsADirectoryError, PermissionError) as err:
        where = f"{err.filename}: " if err.filename else ""
        return _fail(prog, f"{where}{err.strerror or err}", EXIT_BAD_INPUT)
    except KeyboardInterrupt:
        return _fail(prog, "interrupted", EXIT_INTERRUPTED)
    except BrokenPipeError:           # the reader of stdout left (| head): the outputs are written; say nothing
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except Exception as err:  # an unexpected failure: one line unless asked for the traceback
        if os.environ.get("MUTUAL_DEBUG"):
            raise
        return _fail(prog, f"{type(err).__name__}: {_first_line(err)} (set MUTUAL_DEBUG=1 for the traceback)",
                     EXIT_FAILED)


def _show_warning(prog):
    """Warnings about the input (:class:`mutual.inputs.InputWarning`) as one line ``PROG: warning: ...`` on stderr."""
    def show(message, category, filename, lineno, file=None, line=None):
        if category.__name__ == "InputWarning":
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
