"""Columns of a table of text cells (as :func:`.csvtable.read_csv` reads them) turned into numbers and
names, with one way of saying where a bad cell is: ``FILE, line L, column 'C': what is wrong``
(:func:`.csvtable.place`; ``TABLE, row R, column 'C'`` for a table made in memory).
"""

import numpy as np

from .csvtable import place
from .names import check_names
from .values import number_text

__all__ = ["name_column", "number_column", "require_columns"]


MAX_LISTED = 20          # columns named in a message: a file of 200 000 columns is not listed whole


def require_columns(frame, columns):
    """Refuse a table without one of ``columns``, naming the first missing one and the columns it has."""
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        header = list(frame.attrs.get("header", frame.columns))      # the file's columns, read or not
        has = str(header) if len(header) <= MAX_LISTED else f"{header[:MAX_LISTED]} and {len(header) - MAX_LISTED:,} more"
        raise ValueError(f"{place(frame)}: missing column {missing[0]!r} (it has columns {has}; "
                         f"expected {', '.join(map(str, columns))})")


def _texts(column):
    """A column's cells as text as written, an object array ("" where empty; numbers as Python writes them)."""
    cells = column.to_numpy(dtype=object)
    missing = column.isna().to_numpy()
    return np.array(["" if gone else v if isinstance(v, str) else str(v) for v, gone in zip(cells, missing)],
                    dtype=object)


def _shown(value):
    """A cell as the user wrote it: text quoted, numbers plainly (9, not np.float64(9.0))."""
    if isinstance(value, (int, float, np.number)) and not isinstance(value, (bool, np.bool_)):
        return number_text(value)
    return repr(value)


def _fail(frame, mask, column, what):
    rows = np.flatnonzero(mask)
    label = frame.index[rows[0]]
    more = f" ({rows.size - 1} more rows like it)" if rows.size > 1 else ""
    raise ValueError(f"{place(frame, label, column)}: {what(rows[0])}{more}")


def name_column(frame, column, strip=True):
    """The names in ``column`` as a text Series (as written; without surrounding spaces when ``strip``): an
    empty cell, or two spellings that differ only by spaces or Unicode encoding (:func:`.names.check_names`),
    is refused."""
    import pandas as pd
    texts = _texts(frame[column])
    stripped = [t.strip() for t in texts]
    empty = np.array([not t for t in stripped], dtype=bool)
    if empty.any():
        _fail(frame, empty, column, lambda i: "empty")
    check_names(list(texts), column, place(frame), row=lambda i: _row(frame, i))
    return pd.Series(stripped if strip else list(texts), index=frame.index, dtype=str)


def _row(frame, i):
    where = place(frame, frame.index[i])
    return where.split(", ", 1)[1] if ", " in where else where


def number_column(frame, column, allow_empty=False, whole=False, low=None, high=None, what=None,
                  distinct=False):
    """``column`` as floats (nan where empty, with ``allow_empty``), refusing -- naming the file, the line and
    the column of the first -- an empty cell, text, NaN or an infinity, a fraction or a magnitude of 2^53 or more
    where ``whole`` numbers belong, a value below ``low`` or above ``high`` (``what`` says what the column must hold, e.g. ``"a count"``).

    ``distinct``: also refuse two cells written as different numbers that read as the same double (digits
    beyond the 15-17 a double holds, e.g. integers above 2^53): a statistic of them would see no difference.
    """
    import pandas as pd
    raw = frame[column]
    if raw.dtype.kind in "iuf":                               # numbers already (a table made in memory)
        values, texts = raw.to_numpy(dtype=float), None
        empty = np.isnan(values)
    else:
        texts = np.array([t.strip() for t in _texts(raw)], dtype=object)
        empty = texts == ""
        values = pd.to_numeric(np.where(empty, None, texts), errors="coerce").astype(float)
    if not allow_empty and empty.any():
        _fail(frame, empty, column, lambda i: "empty")
    kind = what or ("a whole number" if whole else "a finite number")
    checks = [~empty & ~np.isfinite(values)]
    with np.errstate(invalid="ignore"):
        if whole:
            checks.append(np.mod(np.nan_to_num(values), 1) != 0)
        if low is not None:
            checks.append(values < low)
        if high is not None:
            checks.append(values > high)
    for check in checks:
        if check.any():
            _fail(frame, check, column, lambda i: f"{_shown(raw.iloc[i])} is not {kind}")
    if whole and (np.abs(np.nan_to_num(values)) >= 2 ** 53).any():
        _fail(frame, np.abs(np.nan_to_num(values)) >= 2 ** 53, column,
              lambda i: f"{_shown(raw.iloc[i])} is too large for a whole number here (|{column}| < 2^53: a double "
                        "holds no larger integer exactly)")
    if distinct and texts is not None:
        _check_distinct(frame, column, texts, values)
    return values


def _check_distinct(frame, column, texts, values):
    """Refuse two cells whose numbers differ as written but not as doubles (more digits than a double holds)."""
    import pandas as pd
    from decimal import Decimal
    spelled = pd.DataFrame({"value": values, "text": texts}).drop_duplicates()
    shared = spelled[spelled.duplicated("value", keep=False) & np.isfinite(spelled["value"])]
    for value, group in shared.groupby("value", sort=False):
        exact = {}
        for i, text in zip(group.index, group["text"]):
            exact.setdefault(Decimal(text), i)
            if len(exact) > 1:
                j = next(iter(exact.values()))
                raise ValueError(f"{place(frame, frame.index[i], column)}: {texts[i]} and {texts[j]} "
                                 f"({_row(frame, j)}) differ only beyond the 15-17 significant digits of a double "
                                 f"(both read as {number_text(value)}), so no statistic can tell them apart; subtract "
                                 "a common offset from the column (or change its unit) and run again")
