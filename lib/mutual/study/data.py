"""Tidy CSV schema of the chapter 5 user study, for simulated and real data alike.

Trial table (one row per participant x trial x measure), ``TRIAL_COLUMNS``:

* ``participant`` -- participant id, a string (``P01``, ...);
* ``comparison``  -- the pair of teams, e.g. ``Standard-Learned`` (:func:`mutual.study.design.comparison_label`);
* ``order``       -- 1 or 2, the position of this trial within its comparison;
* ``treatment``   -- the team's safe set: ``Standard``, ``Learned`` or ``Conservative``;
* ``task_version``-- 1..6, the randomized task layout of this trial;
* ``trial``       -- 1..6, the position of the trial in the participant's session;
* ``measure``     -- an objective count of ``OBJECTIVE_MEASURES`` (Phase III, per trial) or a
  7-point Likert answer of ``LIKERT_MEASURES`` (questionnaire after each comparison, one answer
  per team: "I trusted this team", ..., "I preferred this team");
* ``value``       -- the number.

Phase II intervention table: the schema of :mod:`mutual.supervision.supervisor` (``participant``, ``trial``
= the scene watched, ``time`` into the scene, the robot state ``x``, ``y``, ``theta`` relative to
the obstacle centre when the supervisor intervened; optional ``obstacle_x``, ``obstacle_y``).
The same files hold a real study's data; the simulated ones carry ``simulated`` in their names.

The simulated study's tables are written by :func:`mutual.study.cohort.write_simulated_study`.
"""

import numpy as np
import pandas as pd

from ..atomic import atomic_path
from ..supervision.supervisor import validate_interventions
from .design import TREATMENTS, comparison_label

TRIAL_COLUMNS = ["participant", "comparison", "order", "treatment", "task_version", "trial", "measure", "value"]
OBJECTIVE_MEASURES = ("trips", "interventions", "collisions", "false_positives", "score")
COUNT_MEASURES = ("trips", "interventions", "collisions", "false_positives")
LIKERT_MEASURES = ("trust", "performance", "interpretability", "confidence", "fluency", "preference")
LIKERT_RANGE = (1, 7)


def _require_columns(df, columns, name):
    if not isinstance(df, pd.DataFrame):
        raise ValueError(f"{name} must be a pandas DataFrame, got {type(df).__name__}")
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise ValueError(f"{name} is missing columns {missing}")
    nan_cols = [c for c in columns if df[c].isna().any()]
    if nan_cols:
        raise ValueError(f"{name} has missing values (NaN) in columns {nan_cols}")


def _integer_valued(series):
    values = pd.to_numeric(series, errors="coerce")
    return values.notna().all() and np.allclose(values, np.round(values))


def validate_trials(df):
    """Check a trial table against the schema; return it with canonical dtypes.

    Raises ValueError on missing columns, NaN, unknown treatments or measures,
    a comparison that does not contain its treatment, order not 1/2, duplicate
    (participant, trial, measure) rows, a trial with two treatments, negative or
    fractional counts, and Likert answers outside 1..7 or not whole numbers.
    """
    _require_columns(df, TRIAL_COLUMNS, "trial table")
    df = df[TRIAL_COLUMNS].copy()
    bad = sorted(set(df["treatment"]) - set(TREATMENTS))
    if bad:
        raise ValueError(f"trial table: unknown treatment(s) {bad}; expected {TREATMENTS}")
    known = OBJECTIVE_MEASURES + LIKERT_MEASURES
    bad = sorted(set(df["measure"]) - set(known))
    if bad:
        raise ValueError(f"trial table: unknown measure(s) {bad}; expected one of {known}")
    df["participant"] = df["participant"].astype(str)
    if (df["participant"].str.strip() == "").any():
        raise ValueError("trial table: column 'participant' has empty ids")
    for col in ("order", "task_version", "trial"):
        if not _integer_valued(df[col]):
            raise ValueError(f"trial table: column {col!r} must hold whole numbers")
        df[col] = pd.to_numeric(df[col]).astype(int)
    df["value"] = pd.to_numeric(df["value"], errors="coerce")
    if df["value"].isna().any():
        raise ValueError("trial table: column 'value' must be numeric")
    if not df["order"].isin([1, 2]).all():
        raise ValueError("trial table: column 'order' must be 1 or 2")
    parts = df["comparison"].astype(str).str.split("-")
    if not all(len(p) == 2 and p[0] in TREATMENTS and p[1] in TREATMENTS and comparison_label(*p) == "-".join(p)
               for p in parts):
        raise ValueError("trial table: column 'comparison' must name a pair like 'Standard-Learned'")
    if not all(t in p for t, p in zip(df["treatment"], parts)):
        raise ValueError("trial table: a row's treatment is not part of its comparison")
    dup = df.duplicated(["participant", "trial", "measure"], keep=False)
    if dup.any():
        first = df[dup].iloc[0]
        raise ValueError(f"trial table: {int(dup.sum())} duplicate rows for (participant, trial, measure), "
                         f"e.g. ({first['participant']}, {first['trial']}, {first['measure']!r})")
    per_trial = df.groupby(["participant", "trial"])[["treatment", "comparison", "order", "task_version"]].nunique()
    if (per_trial > 1).any().any():
        raise ValueError("trial table: a (participant, trial) has more than one treatment/comparison/order/version")
    counts = df[df["measure"].isin(COUNT_MEASURES)]["value"]
    if (counts < 0).any() or not np.allclose(counts, np.round(counts)):
        raise ValueError(f"trial table: counts {COUNT_MEASURES} must be non-negative whole numbers")
    likert = df[df["measure"].isin(LIKERT_MEASURES)]["value"]
    lo, hi = LIKERT_RANGE
    if ((likert < lo) | (likert > hi)).any() or not np.allclose(likert, np.round(likert)):
        raise ValueError(f"trial table: Likert answers {LIKERT_MEASURES} must be whole numbers in {lo}..{hi}")
    return df


def write_table(df, path, kind):
    """Validate ``df`` as a ``kind`` ('trials' or 'interventions') table and write it atomically as CSV."""
    df = _validator(kind)(df)
    with atomic_path(path) as tmp:
        df.to_csv(tmp, index=False, float_format="%.6g")
    return path


def read_table(path, kind):
    """Read and validate a ``kind`` ('trials' or 'interventions') CSV table."""
    return _validator(kind)(pd.read_csv(path, dtype={"participant": str}))


def _validator(kind):
    if kind not in ("trials", "interventions"):
        raise ValueError(f"kind must be 'trials' or 'interventions', got {kind!r}")
    return validate_trials if kind == "trials" else validate_interventions


def illustrative_questionnaire(design, seed=0):
    """ILLUSTRATIVE Likert answers (not a model of people) to exercise the subjective analysis.

    For every trial of ``design`` (a :func:`mutual.study.design.study_design` table) and every
    measure of ``LIKERT_MEASURES``, an answer drawn uniformly from 1..7, independent of the
    treatment. These numbers say nothing about the thesis's participants.
    """
    rng = np.random.default_rng(seed)
    rows = design.loc[design.index.repeat(len(LIKERT_MEASURES))].reset_index(drop=True)
    rows["participant"] = rows["participant"].map(lambda p: p if isinstance(p, str) else f"P{int(p):02d}")
    rows["measure"] = np.tile(LIKERT_MEASURES, len(design))
    rows["value"] = rng.integers(LIKERT_RANGE[0], LIKERT_RANGE[1] + 1, size=len(rows))
    return validate_trials(rows[TRIAL_COLUMNS])
