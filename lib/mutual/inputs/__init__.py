"""What users give us, read in one place: CSV tables, TOML files, single values and their own code.

* :mod:`.csvtable` -- :func:`read_csv`: a CSV table as text exactly as written, each row with its line
  in the file; :func:`place` names ``FILE, line L, column 'C'``; :func:`write_csv` writes numbers
  exactly (:func:`format_exact`).
* :mod:`.columns` -- a column as numbers (:func:`number_column`) or names (:func:`name_column`),
  refusing a bad cell with its place.
* :mod:`.names` -- one rule for names that differ only by spaces or Unicode encoding (:func:`check_names`).
* :mod:`.tomltable` -- :func:`read_toml` and :class:`Keys`, whose errors name ``FILE: key 'table.key'``.
* :mod:`.values` -- :func:`check_number`: a number within bounds, in one wording, with every digit shown.
* :mod:`.units` -- angles that look like degrees (:func:`angle_unit_warning`, :class:`InputWarning`).
* :mod:`.usercode` -- ``"module:function"`` loaded and called with failures named (:func:`load_function`).

Every loader of the package (study tables, demonstrations, continuous recordings, interventions, worlds,
legibility specs, system files, the compendium's claims and settings) reads through these. Errors are
ValueErrors whose message starts with the file (or the argument) at fault. Importing this package imports
numpy, not pandas (pandas is imported by the functions that build tables).
"""

from .columns import name_column, number_column, require_columns
from .csvtable import Lines, format_exact, line_of, place, read_csv, write_csv
from .names import check_names, name_key
from .tomltable import MAX_DEPTH, Keys, read_toml
from .units import InputWarning, angle_unit_warning, warn
from .usercode import UserFunction, call, load_function
from .values import check_number, count, describe, exact_doubles, finite, number, number_text, positive, probability, real, shown

__all__ = ["InputWarning", "Keys", "Lines", "MAX_DEPTH", "UserFunction", "angle_unit_warning", "call", "check_names",
           "check_number", "count", "describe", "exact_doubles", "finite", "format_exact", "line_of", "load_function", "name_column", "name_key", "number",
           "number_column", "number_text", "place", "positive", "probability", "read_csv", "read_toml", "real", "require_columns", "shown",
           "warn", "write_csv"]
