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
import io
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


class Header(tuple):
    """The file's column names, kept in ``frame.attrs["header"]`` and never copied (as :class:`Lines`)."""

    def __deepcopy__(self, memo):
        return self


def line_of(frame, label, column=None):
    """The file's line that holds row ``label`` (its ``column``'s cell, in a row whose quoted fields
    span several lines) of a table read by :func:`read_csv`; None for a table made in memory."""
    lines = frame.attrs.get("lines")
    if lines is None:
        return None
    return lines[label] + lines.offsets.get((label, column), 0)


def _text(path):
    """The file's text (a UTF-8 byte-order mark dropped), or a ValueError naming the file."""
    try:
        return Path(path).read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not a text file (it is not UTF-8: byte {err.start})") from None


def _quoted_records(path, text):
    """``(start line, fields, line offset of each field or None)`` for every non-blank record of ``text``."""
    reader = csv.reader(io.StringIO(text, newline=""), strict=True)
    before = 0
    try:
        for fields in reader:
            start, before = before + 1, reader.line_num
            if not fields or (len(fields) == 1 and not fields[0].strip()):
                continue                                         # a blank line
            yield start, fields, _offsets(fields) if before > start else None
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


def _check_widths(path, n, wrong, rows):
    """Refuse rows with more or fewer fields than the header's ``n``, naming the line (trailing commas said as
    such); ``wrong``: ``(line, fields)`` of the rows of another width, ``rows``: how many rows there are."""
    if not wrong:
        return
    line, fields = wrong[0]
    if len(fields) > n and all(not f.strip() for f in fields[n:]):
        if len(wrong) == rows:
            raise ValueError(f"{path}, line {line}: every data row has more fields than the header ({len(fields)} "
                             f"against {n}): the rows end with a comma that the header does not; remove the "
                             "trailing commas (or name the extra column in the header)")
        raise ValueError(f"{path}, line {line}: the row has {len(fields)} fields, the header {n}: it ends with an "
                         "extra comma; remove it")
    more = f" ({len(wrong) - 1} more rows like it)" if len(wrong) > 1 else ""
    raise ValueError(f"{path}, line {line}: the row has {len(fields)} fields, the header {n}{more}; every row "
                     "needs one field per column (quote a field that holds a comma)")


def read_csv(path, columns=None, keep=None):
    """The table in the CSV file ``path``: a DataFrame of text exactly as written, NaN where a cell is
    empty, the header's names without surrounding spaces. ``columns``: names that must be present;
    ``keep``: the only columns wanted (those of them the file has are kept, the others are checked for
    their number of fields but never made into columns: a file of 200 000 columns reads in seconds).

    The file's size and its header's width are estimated before it is read (:func:`mutual.budget.csv_table`):
    a file beyond the memory available or the time limit is refused with the estimate. ``frame.attrs`` holds
    ``source`` (the path), ``lines`` (:class:`Lines`: each row's line in the file) for :func:`place` and
    :func:`line_of`, and ``header`` (every column of the file, kept or not). A ValueError names the file (and the
    line) for an empty file, a header without rows, a repeated column name, another delimiter, a row with the
    wrong number of fields, a missing column, a malformed CSV or bytes that are not UTF-8.
    """
    path = Path(path)
    _check_size(path, keep)
    text = _text(path)
    plain = _plain(path, text, columns, keep) if '"' not in text else None
    return plain if plain is not None else _quoted(path, text, columns, keep)


def _check_size(path, keep):
    """Refuse, before reading it, a file whose table would not fit the memory or the time limit."""
    from .. import budget
    try:
        size = path.stat().st_size
        with open(path, "rb") as head:
            width = head.readline(1 << 24).count(b",") + 1       # the header's fields (the first 16 MiB of it)
    except OSError:
        return                                                   # _text names the file and the reason
    columns = width if keep is None else min(width, len(keep))
    budget.check(budget.csv_table(path.name, size, columns))


def _kept(header, keep):
    """The header's names that ``keep`` asks for (all without ``keep``), in the file's order."""
    return list(header) if keep is None else [name for name in header if name in set(keep)]


def _header(path, line, header, columns):
    """The header's names without their spaces, checked (repeated names, another delimiter, missing columns)."""
    _check_header(path, line, header)
    header = [name.strip() for name in header]
    if "" in header:
        raise ValueError(f"{path}, line {line}: column {header.index('') + 1} of the header has no name; name it "
                         "(or remove the column)")
    missing = [c for c in columns or () if c not in header]
    if missing:
        raise ValueError(f"{path}, line {line}: missing column {missing[0]!r} (the file has columns {header}; "
                         f"expected {', '.join(columns)})")
    return header


def _plain(path, text, columns, keep=None):
    """A file without quotes, read by pandas' parser (fast): every line one record. None where the header ends
    with a comma (read as a quoted file: :func:`_quoted` drops an unnamed empty last column)."""
    import numpy as np
    import pandas as pd
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    kept = [(number, line) for number, line in enumerate(lines, start=1) if line.strip()]
    if not kept:
        raise ValueError(f"{path}: the file is empty (expected a header row and data rows)")
    (header_line, head), body = kept[0], kept[1:]
    if head.rstrip().endswith(","):
        return None
    header = _header(path, header_line, head.split(","), columns)
    widths = np.array([line.count(",") for _, line in body], dtype=int) + 1
    wrong = [(body[i][0], body[i][1].split(",")) for i in np.flatnonzero(widths != len(header))]
    _check_widths(path, len(header), wrong, len(body))
    if not body:
        raise ValueError(f"{path}: no data rows after the header")
    frame = pd.read_csv(io.StringIO("\n".join(line for _, line in body)), header=None, names=header, dtype=str,
                        keep_default_na=False, na_values=[""], quoting=csv.QUOTE_NONE, index_col=False,
                        skip_blank_lines=False, usecols=_kept(header, keep))
    return _located(frame, path, [number for number, _ in body], {}, header)


def _quoted(path, text, columns, keep=None):
    """A file with quoted fields, read record by record (a record may span lines)."""
    import numpy as np
    import pandas as pd
    records = list(_quoted_records(path, text))
    if not records:
        raise ValueError(f"{path}: the file is empty (expected a header row and data rows)")
    (header_line, header, _), body = records[0], records[1:]
    _check_header(path, header_line, header)
    header, body = _drop_unnamed_tail([name.strip() for name in header], body)
    header = _header(path, header_line, header, columns)
    _check_widths(path, len(header), [(line, f) for line, f, _ in body if len(f) != len(header)], len(body))
    if not body:
        raise ValueError(f"{path}: no data rows after the header")
    kept = _kept(header, keep)
    where = [header.index(name) for name in kept]
    frame = pd.DataFrame({name: pd.Series([f[j] for _, f, _ in body], dtype=str).replace("", np.nan)
                          for name, j in zip(kept, where)}, columns=kept)
    offsets = {(i, header[j]): o for i, (_, _, offs) in enumerate(body) if offs for j, o in enumerate(offs)
               if o and header[j] in kept}
    return _located(frame, path, [line for line, _, _ in body], offsets, header)


def _located(frame, path, lines, offsets, header):
    """``frame`` with its file, each row's line and the file's header in ``attrs`` (:func:`place`, :func:`line_of`)."""
    import numpy as np
    frame.attrs["source"] = str(path)
    frame.attrs["lines"] = Lines(np.array(lines), offsets)
    frame.attrs["header"] = Header(header)
    return frame


def _drop_unnamed_tail(header, body):
    """Columns at the end of the header with no name and no value in any row (a comma that ends every line)."""
    while header and header[-1] == "" and all(len(f) < len(header) or not f[len(header) - 1].strip()
                                               for _, f, _ in body):
        header = header[:-1]
        body = [(ln, f[:len(header)] if len(f) > len(header) else f, o) for ln, f, o in body]
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
