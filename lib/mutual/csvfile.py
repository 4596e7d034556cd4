"""CSV tables read as the user wrote them and written so that they read back exactly (issue 22).

* :func:`read_text_csv`: every cell as text exactly as written (``01``, ``1``, ``1.0``, ``NA``,
  ``None`` and ``nan`` are distinct names); only an empty cell is missing. A UTF-8 byte-order mark
  and CRLF line ends are accepted. The header is checked first (:func:`check_header`): a
  duplicated column name (which pandas would silently rename ``x.1``) is refused, and a header
  that is one field holding ``;``, a tab or ``|`` is refused with the delimiter the file seems to use.
* :func:`check_names`: names in a column that differ only by surrounding spaces or by Unicode
  normalisation (``"P1"`` and ``"P1 "``) are ambiguous and refused, naming both spellings.
* :func:`format_exact` and :func:`write_csv`: numbers written with the shortest text that reads
  back as the same double (``repr``), whole numbers without ``.0``; written atomically.

Errors are ValueErrors whose message starts with the file name.
"""

import csv
import unicodedata
from pathlib import Path

from .atomic import atomic_path

__all__ = ["check_header", "check_names", "format_exact", "read_text_csv", "write_csv"]

_DELIMITERS = {";": "';' (semicolon)", "\t": "a tab", "|": "'|'"}


def _header(path):
    """The header row as written (first non-blank line, quotes honoured), or None for an empty file."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as handle:
            for row in csv.reader(handle):
                if any(cell.strip() for cell in row):
                    return row
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file (it is not UTF-8)") from None
    except csv.Error as err:
        raise ValueError(f"{path}: not a readable CSV file ({err})") from None
    return None


def check_header(path):
    """Refuse a header with a duplicated column name, or one field that holds another delimiter."""
    header = _header(path)
    if header is None:
        return None
    if len(header) == 1:
        found = [d for d in _DELIMITERS if d in header[0]]
        if found:
            raise ValueError(f"{path}: the header {header[0][:60]!r} is one field; the file seems to use "
                             f"{_DELIMITERS[found[0]]} as its delimiter, but mutual reads comma-separated files "
                             "(save it as CSV with commas)")
    seen = {}
    for position, name in enumerate(header, start=1):
        key = _key(name)
        if key in seen:
            first, spelled = seen[key]
            same = "" if spelled == name else f" (as {spelled!r})"
            raise ValueError(f"{path}: line 1: the column name {name!r} appears twice, as columns {first}{same} and "
                             f"{position}; rename one so that each column has its own name")
        seen[key] = (position, name)
    return header


def read_text_csv(path):
    """The table in the CSV file ``path`` with every cell as text as written; empty cells are NaN.

    The header is checked by :func:`check_header`. A ValueError names the file for an empty file,
    a malformed CSV or bytes that are not UTF-8.
    """
    import pandas as pd
    path = Path(path)
    check_header(path)
    try:
        return pd.read_csv(path, dtype=str, keep_default_na=False, na_values=[""], encoding="utf-8-sig")
    except pd.errors.EmptyDataError:
        raise ValueError(f"{path}: the file is empty (expected a header row and data rows)") from None
    except pd.errors.ParserError as err:
        raise ValueError(f"{path}: not a readable CSV file ({' '.join(str(err).split())})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file (it is not UTF-8)") from None


def _key(name):
    return unicodedata.normalize("NFC", str(name)).strip()


def check_names(values, column, where, row=None):
    """Refuse names of ``column`` that differ only by surrounding spaces or Unicode normalisation.

    ``values``: the column's cells (text); ``where``: the file or table named in the error;
    ``row(i)``: how to name the ``i``-th cell's row (default ``line i + 2``, the header being line 1).
    """
    row = row or (lambda i: f"line {i + 2}")
    seen = {}
    for i, value in enumerate(values):
        if not isinstance(value, str):
            continue
        other = seen.setdefault(_key(value), (value, i))
        if other[0] != value:
            raise ValueError(f"{where}: column {column!r}: {other[0]!r} ({row(other[1])}) and {value!r} ({row(i)}) "
                             "differ only in spaces or in how a character is encoded; write one name the same way "
                             "everywhere")


def format_exact(value):
    """The shortest text that reads back as the same double: ``repr``, with a whole number's ``.0`` dropped."""
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") and text != "-0.0" else text     # "-0" would read back as 0


def write_csv(frame, path):
    """Write the DataFrame ``frame`` to ``path`` atomically, numbers exactly (:func:`format_exact`)."""
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False, float_format=format_exact)
    return Path(path)
