"""What every ``mutual`` command shares: the output options (``--out``, ``--json``,
``--no-progress``), atomic output files, one-line error reports with exit status 2 for bad
input, and progress bars on stderr.

Only the standard library is imported at module level, so that ``mutual --help`` stays fast;
numpy, pandas and matplotlib are imported inside the functions that need them.
"""

import json
import math
import os
import sys
from contextlib import contextmanager
from pathlib import Path

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


class InputError(Exception):
    """Bad input (a file, a column, an option): reported as one line, exit status 2."""


def add_output_options(parser):
    """``--out DIR``, ``--json`` and ``--no-progress`` on a command's parser."""
    group = parser.add_argument_group("output")
    group.add_argument("--out", metavar="DIR", type=Path, default=Path("."),
                       help="folder for the output files, created if missing (default: the current directory); "
                            "each file is written atomically, so an interrupted run leaves no half-written file")
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
    """Turn a ValueError (or a parse error) raised while reading or analysing ``path`` into an
    :class:`InputError` whose message starts with the file name."""
    import pandas as pd
    try:
        yield
    except InputError:
        raise
    except pd.errors.EmptyDataError:
        raise InputError(f"{path}: the file is empty (expected a header row and data rows)") from None
    except pd.errors.ParserError as err:
        raise InputError(f"{path}: not a readable CSV file ({_first_line(err)})") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text file (it is not UTF-8)") from None
    except (ValueError, KeyError, TypeError) as err:
        message = _first_line(err)
        raise InputError(message if str(path) in message else f"{path}: {message}") from None


def read_csv(path):
    """``pandas.read_csv`` with the errors of :func:`about` (file named, one line)."""
    import pandas as pd
    with about(path):
        frame = pd.read_csv(path, dtype={"participant": str})
    if frame.empty:
        raise InputError(f"{path}: no data rows after the header")
    return frame


def require_columns(frame, columns, path):
    """Raise an InputError naming the file and the first missing column."""
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise InputError(f"{path}: missing column {missing[0]!r} (the file has columns {list(frame.columns)})")


def numeric_column(frame, column, path):
    """The column as floats, or an InputError naming the file, the line and the column."""
    import numpy as np
    import pandas as pd
    values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float)
    bad = ~np.isfinite(values)
    if bad.any():
        row = int(bad.argmax())
        line = int(frame.index[row]) + 2     # read_csv numbers data rows from 0; line 1 is the header
        raw = frame[column].iloc[row]
        what = "missing (empty or NA)" if pd.isna(raw) else f"{_shown(raw)} is not a finite number"
        raise InputError(f"{path}: column {column!r}, line {line}: {what}")
    return values


def integer_column(frame, column, path, allow_empty=False):
    """Check that every entry of the column is a whole number (or empty, with ``allow_empty``);
    an InputError names the file, the column and the line of the first that is not."""
    import numpy as np
    import pandas as pd
    raw = frame[column]
    values = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=float)
    empty = raw.isna().to_numpy() | (raw.astype(str).str.strip() == "").to_numpy()
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(values) | (np.mod(values, 1) != 0)
    bad &= ~empty if allow_empty else np.ones_like(bad)
    if bad.any():
        row = int(bad.argmax())
        what = "empty" if empty[row] else f"{_shown(raw.iloc[row])} is not a whole number"
        raise InputError(f"{path}: column {column!r}, line {int(frame.index[row]) + 2}: {what}")


def output_path(args, name):
    """``args.out / name``, refusing an ``--out`` that is a file."""
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: exists and is not a folder")
    return out / name


def write_csv(frame, path, **to_csv):
    """Write a DataFrame atomically."""
    from ..atomic import atomic_path
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False, **to_csv)
    return Path(path)


def save_figure(fig, path):
    """Save a matplotlib figure atomically (PNG, 150 dpi) and close it."""
    import matplotlib.pyplot as plt
    from ..atomic import atomic_path
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=150, bbox_inches="tight", metadata={"Software": None})
    plt.close(fig)
    return Path(path)


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
        args.handler(args)
        return EXIT_OK
    except InputError as err:
        return _fail(prog, str(err), EXIT_BAD_INPUT)
    except (FileNotFoundError, IsADirectoryError, PermissionError) as err:
        where = f"{err.filename}: " if err.filename else ""
        return _fail(prog, f"{where}{err.strerror or err}", EXIT_BAD_INPUT)
    except KeyboardInterrupt:
        return _fail(prog, "interrupted", EXIT_INTERRUPTED)
    except Exception as err:  # an unexpected failure: one line unless asked for the traceback
        if os.environ.get("MUTUAL_DEBUG"):
            raise
        return _fail(prog, f"{type(err).__name__}: {_first_line(err)} (set MUTUAL_DEBUG=1 for the traceback)",
                     EXIT_FAILED)


def _fail(prog, message, status):
    print(f"{prog}: error: {message}", file=sys.stderr)
    return status


def _shown(value):
    """A cell's value as the user wrote it: numbers plainly, text quoted."""
    if hasattr(value, "item"):
        value = value.item()
    return repr(value) if isinstance(value, str) else f"{value:g}" if isinstance(value, float) else str(value)


def _first_line(err):
    text = str(err).strip() or type(err).__name__
    return " ".join(text.split())
