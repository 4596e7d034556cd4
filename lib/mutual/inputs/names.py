"""Names in users' tables (participants, demonstrations, levels, column names): text as written, and
one rule for names that only look alike.

Two spellings of a name in one column that differ only by surrounding spaces or by how a character
is encoded in Unicode (``"P1"`` and ``"P1 "``; ``"é"`` composed or as ``e`` + accent) are
ambiguous: did the user mean one name or two? Every reader refuses them (:func:`check_names`), naming
both spellings and where they stand, rather than merging them silently or keeping them apart.
"""

import unicodedata

__all__ = ["check_names", "name_key"]


def name_key(name):
    """What two spellings of one name share: the text in Unicode's composed form (NFC), without
    surrounding spaces."""
    return unicodedata.normalize("NFC", str(name)).strip()


def check_names(values, column, where, row=None):
    """Refuse names of ``column`` that differ only by surrounding spaces or Unicode normalisation.

    ``values``: the column's cells (text; other cells are skipped); ``where``: the file or table
    named in the error; ``row(i)``: how to name the ``i``-th cell's place (default ``line i + 2``,
    the header being line 1).
    """
    row = row or (lambda i: f"line {i + 2}")
    first = {}
    for i, value in enumerate(values):
        if isinstance(value, str) and value not in first:
            first[value] = i                                  # each spelling once: a column holds few names
    seen = {}
    for value, i in first.items():
        other = seen.setdefault(name_key(value), (value, i))
        if other[0] != value:
            raise ValueError(f"{where}: column {column!r}: {other[0]!r} ({row(other[1])}) and {value!r} ({row(i)}) "
                             "differ only in spaces or in how a character is encoded; write one name the same way "
                             "everywhere")
