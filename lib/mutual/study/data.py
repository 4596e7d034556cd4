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

Errors name the file, the line of the file (the header is line 1) and the column
(:mod:`mutual.inputs`). The
simulated study's tables are written by :func:`mutual.study.cohort.write_simulated_study`.
"""

from pathlib import Path

import numpy as np
import pandas as pd

from ..atomic import atomic_path
from ..inputs import format_exact, name_column, number_column, place, read_csv, require_columns
from .design import DESIGN_COLUMNS

TRIAL_COLUMNS = ["participant", "comparison", "order", "treatment", "task_version", "trial", "measure", "value"]
OBJECTIVE_MEASURES = ("trips", "interventions", "collisions", "false_positives", "score")
COUNT_MEASURES = ("trips", "interventions", "collisions", "false_positives")
LIKERT_MEASURES = ("trust", "performance", "interpretability", "confidence", "fluency", "preference")
LIKERT_RANGE = (1, 7)
KINDS = ("trials", "long", "interventions")


def _named(df, where, name):
    """``df`` as a table :func:`mutual.inputs.place` names: a file's rows by their line (a table read by
    :func:`mutual.inputs.read_csv` keeps its ``source``), a table made in memory as ``name, row R``."""
    if not isinstance(df, pd.DataFrame):
        raise ValueError(f"{where or name} must be a pandas DataFrame, got {type(df).__name__}")
    if df.attrs.get("source") is None:
        df = df.copy()
        df.attrs["name"] = where or name
    return df


def _require(df, columns):
    require_columns(df, columns)
    if len(df) == 0:
        raise ValueError(f"{place(df)}: has no rows")
    for col in columns:
        empty = df[col].isna().to_numpy() | (df[col].astype(str).str.strip() == "").to_numpy()
        if empty.any():
            raise ValueError(f"{place(df, df.index[np.flatnonzero(empty)[0]], col)}: empty")


def validate_trials(df, treatments=None, where=None):
    """Check a trial table (module docstring) and return it with canonical dtypes.

    ``treatments``: the allowed treatment names (default: any); ``where``: how errors name a table made in
    memory (default "trial table"; a table read from a file is named by its file and lines). Raises
    ValueError naming the row and column for missing columns or values, non-numeric values, ``order`` not
    1/2, a comparison that does not name its row's treatment, a (participant, comparison) with more than two
    treatments, duplicate (participant, trial, measure) rows, a trial with two treatments, negative or
    fractional counts, and Likert answers outside 1..7 or not whole numbers.
    """
    df = _named(df, where, "trial table")
    _require(df, TRIAL_COLUMNS)
    df = df[TRIAL_COLUMNS].copy()
    for col in ("participant", "comparison", "treatment", "measure"):
        df[col] = name_column(df, col)
    if treatments is not None:
        if isinstance(treatments, str) or not hasattr(treatments, "__iter__"):
            raise ValueError(f"treatments must be a list of names, got {treatments!r}")
        allowed = [str(t) for t in treatments]
        bad = ~df["treatment"].isin(allowed).to_numpy()
        if bad.any():
            i = _first(bad)
            raise ValueError(f"{place(df, df.index[i], 'treatment')}: unknown treatment {df['treatment'].iloc[i]!r}; "
                             f"expected one of {allowed}")
    df["order"] = number_column(df, "order", whole=True, low=1, high=2, what="1 or 2").astype(int)
    for col in ("task_version", "trial"):
        df[col] = number_column(df, col, whole=True).astype(int)
    df["value"] = number_column(df, "value", what="a number")
    _check_comparisons(df)
    counts = df["measure"].isin(COUNT_MEASURES).to_numpy()
    if counts.any():
        number_column(df[counts], "value", whole=True, low=0,
                      what=f"a count (a non-negative whole number, as {COUNT_MEASURES} must be)")
    likert = df["measure"].isin(LIKERT_MEASURES).to_numpy()
    if likert.any():
        lo, hi = LIKERT_RANGE
        number_column(df[likert], "value", whole=True, low=lo, high=hi,
                      what=f"a Likert answer (a whole number in {lo}..{hi})")
    out = df.reset_index(drop=True)
    out.attrs.clear()
    return out


def _first(mask):
    return int(np.flatnonzero(np.asarray(mask))[0])


def _check_comparisons(df):
    """Each row's comparison names its treatment; two treatments per comparison; one row per (participant, trial,
    measure); one treatment, comparison, order and task version per trial."""
    named = [c.startswith(t + "-") or c.endswith("-" + t) for c, t in zip(df["comparison"], df["treatment"])]
    if not all(named):
        i = named.index(False)
        raise ValueError(f"{place(df, df.index[i], 'comparison')}: {df['comparison'].iloc[i]!r} does not name this "
                         f"row's treatment {df['treatment'].iloc[i]!r} (expected '<A>-<B>' with it as A or B)")
    pairs = df.groupby(["participant", "comparison"])["treatment"].nunique()
    if (pairs > 2).any():
        who = pairs[pairs > 2].index[0]
        raise ValueError(f"{place(df)}: participant {who[0]!r} has more than two treatments in comparison {who[1]!r}")
    dup = df.duplicated(["participant", "trial", "measure"], keep="first").to_numpy()
    if dup.any():
        i = _first(dup)
        raise ValueError(f"{place(df, df.index[i])}: duplicate row for (participant, trial, measure) = "
                         f"({df['participant'].iloc[i]}, {df['trial'].iloc[i]}, {df['measure'].iloc[i]!r})")
    per_trial = df.groupby(["participant", "trial"])[["treatment", "comparison", "order", "task_version"]].nunique()
    if (per_trial > 1).any().any():
        who = per_trial[(per_trial > 1).any(axis=1)].index[0]
        raise ValueError(f"{place(df)}: participant {who[0]!r}, trial {who[1]} has more than one "
                         "treatment/comparison/order/task_version")


def validate_long(df, dv, within, subject, where=None):
    """Check a long table for a repeated-measures analysis: the columns ``dv``, ``within`` and
    ``subject`` exist and are filled, and ``dv`` holds finite numbers (errors name row and column).
    Returns a copy with ``dv`` as float and ``within``/``subject`` as given."""
    for arg, name in (("dv", dv), ("within", within), ("subject", subject)):
        if not isinstance(name, str) or not name:
            raise ValueError(f"{arg} must name a column (a non-empty string), got {name!r}")
    if len({dv, within, subject}) < 3:
        raise ValueError(f"dv, within and subject must be three different columns, got {dv!r}, {within!r}, {subject!r}")
    df = _named(df, where, "data")
    _require(df, [dv, within, subject])
    for col in (within, subject):
        name_column(df, col, strip=False)
    out = df.copy()
    out[dv] = number_column(df, dv, what="a number", distinct=True)
    out = out.reset_index(drop=True)
    out.attrs.clear()
    return out


def _validate_interventions(df):
    """Chapter 4's validator (:func:`mutual.supervision.validate_interventions`)."""
    from ..supervision import validate_interventions
    return validate_interventions(df)


def _validate(df, kind, where, options):
    if kind == "trials":
        return validate_trials(df, options.get("treatments"), where)
    if kind == "long":
        return validate_long(df, options.get("dv"), options.get("within"), options.get("subject"), where)
    return _validate_interventions(df)


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
    the line and the column (:func:`mutual.inputs.read_csv`).
    """
    _check_kind(kind, options)
    if not isinstance(path, (str, Path)):
        raise ValueError(f"path must be a file path, got {type(path).__name__}")
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    return _validate(read_csv(path), kind, None, options)


def write_table(df, path, kind="trials", digits=None, **options):
    """Check ``df`` as a ``kind`` table (see :func:`read_table`) and write it atomically as CSV.

    Numbers are written exactly (they read back as the same doubles, :func:`mutual.inputs.format_exact`);
    ``digits=d`` rounds them to ``d`` significant digits instead (a presentation choice).
    """
    _check_kind(kind, options)
    if digits is not None and (isinstance(digits, bool) or not isinstance(digits, int) or not 1 <= digits <= 17):
        raise ValueError(f"digits must be None (exact) or a whole number in 1..17, got {digits!r}")
    df = _validate(df, kind, f"{kind} table", options)
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
