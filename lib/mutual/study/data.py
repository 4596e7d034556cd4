"""Tidy CSV tables of a user study like chapter 5's, for simulated and real data alike.

Trial table (``kind="trials"``; one row per participant x trial x measure), ``TRIAL_COLUMNS``:

* ``participant`` -- participant id, a string (``P01``, ...);
* ``comparison``  -- the pair of teams compared, ``<A>-<B>`` (e.g. ``Standard-Learned``); the row's
  treatment is one of the two;
* ``order``       -- 1 or 2, the position of this trial within its comparison;
* ``treatment``   -- the condition (the team's safe set); any names, the thesis's ``Standard``,
  ``Learned`` and ``Conservative`` are only the study notebook's default;
* ``task_version``-- whole number, the randomized task layout of this trial;
* ``trial``       -- whole number, the position of the trial in the participant's session;
* ``measure``     -- what ``value`` measures: the thesis's objective counts ``COUNT_MEASURES`` and
  ``score`` (Phase III, per trial), its 7-point Likert answers ``LIKERT_MEASURES`` (questionnaire
  after each comparison, one answer per team), or any other name;
* ``value``       -- the number (counts: non-negative whole numbers; Likert answers: 1..7).

Long table (``kind="long"``): any CSV with one row per observation and the three columns a
repeated-measures analysis needs, named by the caller: ``dv`` (numbers), ``within`` (the level)
and ``subject`` (participant ids); other columns are kept as they are.

Interventions table (``kind="interventions"``): the schema of :mod:`mutual.supervision.supervisor`
(``participant``, ``trial`` = the scene watched, ``time`` into the scene, the robot state ``x``,
``y``, ``theta`` relative to the obstacle centre at the intervention; optional ``obstacle_x``,
``obstacle_y``).

Errors name the file, the line of the file (the header is line 1) and the column. The
simulated study's tables are written by :func:`mutual.study.cohort.write_simulated_study`.
"""

from pathlib import Path

import numpy as np
import pandas as pd

from ..atomic import atomic_path
from ..csvfile import check_header, check_names, format_exact
from .design import DESIGN_COLUMNS

TRIAL_COLUMNS = ["participant", "comparison", "order", "treatment", "task_version", "trial", "measure", "value"]
OBJECTIVE_MEASURES = ("trips", "interventions", "collisions", "false_positives", "score")
COUNT_MEASURES = ("trips", "interventions", "collisions", "false_positives")
LIKERT_MEASURES = ("trust", "performance", "interpretability", "confidence", "fluency", "preference")
LIKERT_RANGE = (1, 7)
KINDS = ("trials", "long", "interventions")


class _Where:
    """Names a row of a table: ``<file>, line N`` for a table read from a CSV file (header = line 1)."""

    def __init__(self, name, path=None):
        self.name, self.path = name, path

    def row(self, frame, position):
        if self.path is not None:
            return f"{self.path}, line {position + 2}"
        return f"{self.name}, row {frame.index[position]!r}"

    def table(self):
        return str(self.path) if self.path is not None else self.name


def _first(mask):
    return int(np.flatnonzero(np.asarray(mask))[0])


def _require(df, columns, where):
    if not isinstance(df, pd.DataFrame):
        raise ValueError(f"{where.table()} must be a pandas DataFrame, got {type(df).__name__}")
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise ValueError(f"{where.table()}: missing column(s) {missing} (it has {list(df.columns)})")
    if len(df) == 0:
        raise ValueError(f"{where.table()}: has no rows")
    for col in columns:
        empty = df[col].isna().to_numpy() | (df[col].astype(str).str.strip() == "").to_numpy()
        if empty.any():
            raise ValueError(f"{where.row(df, _first(empty))}, column {col!r}: missing value")


def _numbers(df, col, where, whole=False, low=None, high=None, what="a number"):
    values = pd.to_numeric(df[col], errors="coerce")
    bad = values.isna().to_numpy() | ~np.isfinite(values.to_numpy(dtype=float))
    if not bad.any() and whole:
        bad = values.to_numpy(dtype=float) != np.round(values.to_numpy(dtype=float))
    if not bad.any() and low is not None:
        bad = values.to_numpy(dtype=float) < low
    if not bad.any() and high is not None:
        bad = values.to_numpy(dtype=float) > high
    if bad.any():
        i = _first(bad)
        raise ValueError(f"{where.row(df, i)}, column {col!r}: {_show(df[col].iloc[i])} is not {what}")
    return values


def _show(value):
    """A cell as the user wrote it: text quoted, numbers plainly (9, not np.float64(9.0))."""
    if isinstance(value, (int, float, np.number)) and not isinstance(value, bool):
        return f"{float(value):g}"
    return repr(value)


def validate_trials(df, treatments=None, where=None):
    """Check a trial table (module docstring) and return it with canonical dtypes.

    ``treatments``: the allowed treatment names (default: any). Raises ValueError naming the row
    and column for missing columns or values, non-numeric values, ``order`` not 1/2, a comparison
    that does not name its row's treatment, a (participant, comparison) with more than two
    treatments, duplicate (participant, trial, measure) rows, a trial with two treatments,
    negative or fractional counts, and Likert answers outside 1..7 or not whole numbers.
    """
    where = where or _Where("trial table")
    _require(df, TRIAL_COLUMNS, where)
    df = df[TRIAL_COLUMNS].copy()
    for col in ("participant", "comparison", "treatment", "measure"):
        df[col] = df[col].astype(str)
        check_names(df[col], col, where.table(), _row_namer(df, where))
        df[col] = df[col].str.strip()
    if treatments is not None:
        if isinstance(treatments, str) or not hasattr(treatments, "__iter__"):
            raise ValueError(f"treatments must be a list of names, got {treatments!r}")
        allowed = [str(t) for t in treatments]
        bad = ~df["treatment"].isin(allowed).to_numpy()
        if bad.any():
            i = _first(bad)
            raise ValueError(f"{where.row(df, i)}, column 'treatment': unknown treatment {df['treatment'].iloc[i]!r}; "
                             f"expected one of {allowed}")
    df["order"] = _numbers(df, "order", where, whole=True, low=1, high=2, what="1 or 2").astype(int)
    for col in ("task_version", "trial"):
        df[col] = _numbers(df, col, where, whole=True, what="a whole number").astype(int)
    df["value"] = _numbers(df, "value", where).astype(float)
    named = [c.startswith(t + "-") or c.endswith("-" + t) for c, t in zip(df["comparison"], df["treatment"])]
    if not all(named):
        i = named.index(False)
        raise ValueError(f"{where.row(df, i)}, column 'comparison': {df['comparison'].iloc[i]!r} does not name this "
                         f"row's treatment {df['treatment'].iloc[i]!r} (expected '<A>-<B>' with it as A or B)")
    pairs = df.groupby(["participant", "comparison"])["treatment"].nunique()
    if (pairs > 2).any():
        who = pairs[pairs > 2].index[0]
        raise ValueError(f"{where.table()}: participant {who[0]!r} has more than two treatments in comparison {who[1]!r}")
    dup = df.duplicated(["participant", "trial", "measure"], keep="first").to_numpy()
    if dup.any():
        i = _first(dup)
        raise ValueError(f"{where.row(df, i)}: duplicate row for (participant, trial, measure) = "
                         f"({df['participant'].iloc[i]}, {df['trial'].iloc[i]}, {df['measure'].iloc[i]!r})")
    per_trial = df.groupby(["participant", "trial"])[["treatment", "comparison", "order", "task_version"]].nunique()
    if (per_trial > 1).any().any():
        who = per_trial[(per_trial > 1).any(axis=1)].index[0]
        raise ValueError(f"{where.table()}: participant {who[0]!r}, trial {who[1]} has more than one "
                         "treatment/comparison/order/task_version")
    counts = df["measure"].isin(COUNT_MEASURES).to_numpy()
    if counts.any():
        _numbers(df[counts], "value", _Shifted(where, np.flatnonzero(counts), df), whole=True, low=0,
                 what=f"a count (a non-negative whole number, as {COUNT_MEASURES} must be)")
    likert = df["measure"].isin(LIKERT_MEASURES).to_numpy()
    if likert.any():
        lo, hi = LIKERT_RANGE
        _numbers(df[likert], "value", _Shifted(where, np.flatnonzero(likert), df), whole=True, low=lo, high=hi,
                 what=f"a Likert answer (a whole number in {lo}..{hi})")
    return df.reset_index(drop=True)


class _Shifted(_Where):
    """A :class:`_Where` for a subset of a table's rows (``positions`` in the full table)."""

    def __init__(self, where, positions, full):
        super().__init__(where.name, where.path)
        self.positions, self.full = positions, full

    def row(self, frame, position):
        return super().row(self.full, int(self.positions[position]))


def validate_long(df, dv, within, subject, where=None):
    """Check a long table for a repeated-measures analysis: the columns ``dv``, ``within`` and
    ``subject`` exist and are filled, and ``dv`` holds finite numbers (errors name row and column).
    Returns a copy with ``dv`` as float and ``within``/``subject`` as given."""
    where = where or _Where("data")
    for arg, name in (("dv", dv), ("within", within), ("subject", subject)):
        if not isinstance(name, str) or not name:
            raise ValueError(f"{arg} must name a column (a non-empty string), got {name!r}")
    if len({dv, within, subject}) < 3:
        raise ValueError(f"dv, within and subject must be three different columns, got {dv!r}, {within!r}, {subject!r}")
    _require(df, [dv, within, subject], where)
    for col in (within, subject):
        check_names(df[col], col, where.table(), _row_namer(df, where))
    out = df.copy()
    out[dv] = _numbers(df, dv, where).astype(float)
    return out.reset_index(drop=True)


def _row_namer(df, where):
    """How :func:`mutual.csvfile.check_names` names the ``i``-th row of ``df``: its file line or its label."""
    return (lambda i: f"line {i + 2}") if where.path is not None else (lambda i: f"row {df.index[i]!r}")


def _validate_interventions(df, where):
    """Row-level checks of an interventions table (naming the row and column), then chapter 4's validator."""
    from ..supervision import OPTIONAL_COLUMNS, REQUIRED_COLUMNS, validate_interventions
    _require(df, list(REQUIRED_COLUMNS), where)
    _numbers(df, "trial", where, whole=True, low=0, what="a non-negative whole number")
    _numbers(df, "time", where, low=0, what="a non-negative number of seconds")
    for col in ("x", "y", "theta") + tuple(c for c in OPTIONAL_COLUMNS if c in df.columns):
        _numbers(df, col, where, what="a finite number")
    try:
        return validate_interventions(df)
    except ValueError as err:
        raise ValueError(f"{where.table()}: {err}") from None


def _validate(df, kind, where, options):
    if kind == "trials":
        return validate_trials(df, options.get("treatments"), where)
    if kind == "long":
        return validate_long(df, options.get("dv"), options.get("within"), options.get("subject"), where)
    return _validate_interventions(df, where)


def _check_kind(kind, options):
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    allowed = {"trials": {"treatments"}, "long": {"dv", "within", "subject"}, "interventions": set()}[kind]
    unknown = sorted(set(options) - allowed)
    if unknown:
        raise ValueError(f"kind={kind!r} takes no option(s) {unknown} (it takes {sorted(allowed) or 'none'})")
    if kind == "long" and not {"dv", "within", "subject"} <= set(options):
        raise ValueError("kind='long' needs dv=, within= and subject= (the column names)")


def read_table(path, kind="trials", **options):
    """Read and check a CSV table of ``kind`` 'trials', 'long' or 'interventions' (module docstring).

    Options: ``treatments=`` (trials: the allowed names; default any), ``dv=``, ``within=``,
    ``subject=`` (long: the column names, required). A missing file raises FileNotFoundError; an
    empty file, a malformed CSV, a missing column or a bad value raises ValueError naming the file,
    the line and the column.
    """
    _check_kind(kind, options)
    if not isinstance(path, (str, Path)):
        raise ValueError(f"path must be a file path, got {type(path).__name__}")
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    check_header(path)
    try:
        df = pd.read_csv(path, dtype=str, keep_default_na=False, encoding="utf-8-sig")
    except pd.errors.EmptyDataError:
        raise ValueError(f"{path}: the file is empty (no header row, no data)") from None
    except pd.errors.ParserError as err:
        raise ValueError(f"{path}: not a well-formed CSV file ({str(err).strip()})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file") from None
    if len(df) == 0:
        raise ValueError(f"{path}: has a header but no data rows")
    df.columns = [c.strip() for c in df.columns]     # "a, b" headers; check_header refused "b" twice
    df = df.replace("", np.nan)
    return _validate(df, kind, _Where(str(path), path), options)


def write_table(df, path, kind="trials", digits=None, **options):
    """Check ``df`` as a ``kind`` table (see :func:`read_table`) and write it atomically as CSV.

    Numbers are written exactly (they read back as the same doubles, :func:`mutual.csvfile.format_exact`);
    ``digits=d`` rounds them to ``d`` significant digits instead (a presentation choice).
    """
    _check_kind(kind, options)
    if digits is not None and (isinstance(digits, bool) or not isinstance(digits, int) or not 1 <= digits <= 17):
        raise ValueError(f"digits must be None (exact) or a whole number in 1..17, got {digits!r}")
    df = _validate(df, kind, _Where(f"{kind} table"), options)
    with atomic_path(path) as tmp:
        df.to_csv(tmp, index=False, float_format=format_exact if digits is None else f"%.{digits}g")
    return path


def illustrative_questionnaire(design, seed=0):
    """ILLUSTRATIVE Likert answers (not a model of people) to exercise the subjective analysis.

    For every trial of ``design`` (a :func:`mutual.study.design.study_design` table) and every
    measure of ``LIKERT_MEASURES``, an answer drawn uniformly from 1..7, independent of the
    treatment. These numbers say nothing about the thesis's participants.
    """
    if not isinstance(design, pd.DataFrame) or any(c not in design.columns for c in DESIGN_COLUMNS):
        raise ValueError(f"design must be a DataFrame with columns {DESIGN_COLUMNS} (a study_design table)")
    rng = np.random.default_rng(seed)
    rows = design.loc[design.index.repeat(len(LIKERT_MEASURES))].reset_index(drop=True)
    rows["participant"] = rows["participant"].map(lambda p: p if isinstance(p, str) else f"P{int(p):02d}")
    rows["measure"] = np.tile(LIKERT_MEASURES, len(design))
    rows["value"] = rng.integers(LIKERT_RANGE[0], LIKERT_RANGE[1] + 1, size=len(rows))
    return validate_trials(rows[TRIAL_COLUMNS])
