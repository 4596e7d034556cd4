"""CSV tables read as the user wrote them, and written so that they read back exactly.

* :func:`read_csv`: every cell as text exactly as written (``01``, ``1``, ``1.0``, ``NA``, ``None``
  and ``nan`` are distinct names); only an empty cell is missing. A UTF-8 byte-order mark and CRLF
  line ends are accepted; blank lines are skipped. Each row keeps the line of the file it starts on
  (:func:`line_of`), so that an error names the file's own line after quoted fields that hold line
  breaks and after blank lines. Refused, naming the file and the line: a header that repeats a
  column name (pandas would silently rename it ``x.1``), a header that is one field holding ``;``,
  a tab or ``|`` (the delimiter the file seems to use is named), and a row with more or fewer fields
  than the header -- a comma at the end of every data row but not of the header is said as such
  (pandas would shift the columns by one).
* :func:`format_exact` and :func:`write_csv`: numbers written with the shortest text that reads
  back as the same double (``repr``), whole numbers without ``.0``; written atomically.

Errors are ValueErrors whose message starts with the file name, then ``line L`` and ``column 'C'``
where they apply (:func:`place`).
"""

import csv
from pathlib import Path

from ..atomic import atomic_path
from .names import name_key

__all__ = ["Lines", "format_exact", "line_of", "place", "read_csv", "write_csv"]

_DELIMITERS = {";": "';' (semicolon)", "\t": "a tab", "|": "'|'"}


def place(frame, label=None, column=None):
    """``'FILE, line L, column 'C''`` for the row ``label`` of a table read by :func:`read_csv` (the row's
    index label ``label`` for a table made in memory), or the file (table) alone without ``label``."""
    source = frame.attrs.get("source") if hasattr(frame, "attrs") else None
    parts = [str(source) if source is not None else str(frame.attrs.get("name", "table"))]
    if label is not None:
        line = line_of(frame, label, column)
        parts.append(f"line {line}" if line is not None else f"row {label!r}")
    if column is not None:
        parts.append(f"column {column!r}")
    return ", ".join(parts)


class Lines:
    """Each row's line in the file (``lines[label]``; ``np.asarray(lines)`` for all) and, for rows whose quoted
    fields hold line breaks, how far below it each cell starts. Kept in ``frame.attrs["lines"]``: pandas copies
    a table's attrs on every operation, and this copies nothing (one read's lines are one object)."""
    __slots__ = ("array", "offsets")

    def __init__(self, array, offsets):
        self.array, self.offsets = array, offsets

    def __getitem__(self, label):
        return int(self.array[label])

    def __array__(self, dtype=None, copy=None):
        return self.array if dtype is None else self.array.astype(dtype)

    def __len__(self):
        return len(self.array)

    def __deepcopy__(self, memo):
        return self


def line_of(frame, label, column=None):
    """The file's line that holds row ``label`` (its ``column``'s cell, in a row whose quoted fields
    span several lines) of a table read by :func:`read_csv`; None for a table made in memory."""
    lines = frame.attrs.get("lines")
    if lines is None:
        return None
    return lines[label] + lines.offsets.get((label, column), 0)


def _open_rows(path):
    """``(start line, fields, line offset of each field or None)`` for every non-blank record of the file."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as handle:
            reader = csv.reader(handle, strict=True)
            before = 0
            for fields in reader:
                start, before = before + 1, reader.line_num
                if not fields or (len(fields) == 1 and not fields[0].strip()):
                    continue                                         # a blank line
                yield start, fields, _offsets(fields) if before > start else None
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not a text file (it is not UTF-8: byte {err.start})") from None
    except csv.Error as err:
        raise ValueError(f"{path}, line {reader.line_num}: not a readable CSV file ({err}; a field that holds a "
                         "comma, a quote or a line break must be quoted, its quotes doubled)") from None


def _offsets(fields):
    """How many lines below the record's first line each field starts (quoted line breaks)."""
    out, below = [], 0
    for field in fields:
        out.append(below)
        below += field.count("\n") + field.count("\r") - field.count("\r\n")
    return out if below else None


def _check_header(path, line, header):
    if len(header) == 1:
        found = [d for d in _DELIMITERS if d in header[0]]
        if found:
            raise ValueError(f"{path}: the header {header[0][:60]!r} is one field; the file seems to use "
                             f"{_DELIMITERS[found[0]]} as its delimiter, but mutual reads comma-separated files "
                             "(save it as CSV with commas)")
    seen = {}
    for position, name in enumerate(header, start=1):
        key = name_key(name)
        if key in seen:
            first, spelled = seen[key]
            same = "" if spelled == name else f" (as {spelled!r})"
            raise ValueError(f"{path}, line {line}: the column name {name!r} appears twice, as columns {first}{same} "
                             f"and {position}; rename one so that each column has its own name")
        seen[key] = (position, name)


def _check_widths(path, header, body):
    """Refuse rows with more or fewer fields than the header, naming the line (trailing commas said as such)."""
    n = len(header)
    wrong = [(line, fields) for line, fields, _ in body if len(fields) != n]
    if not wrong:
        return
    line, fields = wrong[0]
    if len(fields) > n and all(not f.strip() for f in fields[n:]):
        if len(wrong) == len(body):
            raise ValueError(f"{path}, line {line}: every data row has more fields than the header ({len(fields)} "
                             f"against {n}): the rows end with a comma that the header does not; remove the "
                             "trailing commas (or name the extra column in the header)")
        raise ValueError(f"{path}, line {line}: the row has {len(fields)} fields, the header {n}: it ends with an "
                         "extra comma; remove it")
    more = f" ({len(wrong) - 1} more rows like it)" if len(wrong) > 1 else ""
    raise ValueError(f"{path}, line {line}: the row has {len(fields)} fields, the header {n}{more}; every row "
                     "needs one field per column (quote a field that holds a comma)")


def read_csv(path, columns=None):
    """The table in the CSV file ``path``: a DataFrame of text exactly as written, NaN where a cell is
    empty, the header's names without surrounding spaces. ``columns``: names that must be present.

    ``frame.attrs`` holds ``source`` (the path) and ``lines`` (:class:`Lines`: each row's line in the file) for
    :func:`place` and :func:`line_of`. A ValueError names the file (and the line) for an empty file,
    a header without rows, a repeated column name, another delimiter, a row with the wrong number of
    fields, a missing column, a malformed CSV or bytes that are not UTF-8.
    """
    import numpy as np
    import pandas as pd
    path = Path(path)
    records = list(_open_rows(path))
    if not records:
        raise ValueError(f"{path}: the file is empty (expected a header row and data rows)")
    (header_line, header, _), body = records[0], records[1:]
    _check_header(path, header_line, header)
    header = [name.strip() for name in header]
    header, body = _drop_unnamed_tail(path, header_line, header, body)
    _check_widths(path, header, body)
    if columns is not None:
        missing = [c for c in columns if c not in header]
        if missing:
            raise ValueError(f"{path}, line {header_line}: missing column {missing[0]!r} (the file has columns "
                             f"{header}; expected {', '.join(columns)})")
    if not body:
        raise ValueError(f"{path}: no data rows after the header")
    columns = zip(*(fields for _, fields, _ in body))
    frame = pd.DataFrame({name: pd.Series(cells, dtype=str).replace("", np.nan) for name, cells in zip(header, columns)},
                         columns=header)
    offsets = {(i, header[j]): o for i, (_, _, offs) in enumerate(body) if offs for j, o in enumerate(offs) if o}
    frame.attrs["source"] = str(path)
    frame.attrs["lines"] = Lines(np.array([line for line, _, _ in body]), offsets)
    return frame


def _drop_unnamed_tail(path, line, header, body):
    """Columns at the end of the header with no name and no value in any row (a comma that ends every line)."""
    while header and header[-1] == "" and all(len(f) < len(header) or not f[len(header) - 1].strip()
                                               for _, f, _ in body):
        header = header[:-1]
        body = [(ln, f[:len(header)] if len(f) > len(header) else f, o) for ln, f, o in body]
    if "" in header:
        raise ValueError(f"{path}, line {line}: column {header.index('') + 1} of the header has no name; name it "
                         "(or remove the column)")
    return header, body


def format_exact(value):
    """The shortest text that reads back as the same double: ``repr``, with a whole number's ``.0`` dropped."""
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") and text != "-0.0" else text     # "-0" would read back as 0


def write_csv(frame, path):
    """Write the DataFrame ``frame`` to ``path`` atomically, numbers exactly (:func:`format_exact`)."""
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False, float_format=format_exact)
    return Path(path)
