"""The subject x level table of a repeated-measures data set (section 5.3.1), with the checks an
analysis needs: named columns, numbers, one row per cell (or their mean), a balanced design.
:func:`cell_table` is what :func:`mutual.study.stats.rm_anova` analyses."""

import numpy as np
import pandas as pd

from ..inputs import exact_doubles


def _select_measure(data, dv):
    """Tidy trial tables (``measure`` and ``value`` columns): ``dv`` may name a measure."""
    if isinstance(data, pd.DataFrame) and isinstance(dv, str) and dv not in data.columns \
            and {"measure", "value"} <= set(data.columns) and (data["measure"] == dv).any():
        return data.loc[data["measure"] == dv].rename(columns={"value": dv})
    return data


def _column_names(data, dv, within, subject):
    if not isinstance(data, pd.DataFrame):
        raise ValueError(f"data must be a pandas DataFrame, got {type(data).__name__}")
    names = {"dv": dv, "within": within, "subject": subject}
    for arg, name in names.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"{arg} must name a column (a non-empty string), got {name!r}")
    if len(set(names.values())) < 3:
        raise ValueError(f"dv, within and subject must be three different columns, got {dv!r}, {within!r}, {subject!r}")
    missing = [c for c in names.values() if c not in data.columns]
    if missing:
        raise ValueError(f"data is missing columns {missing} (it has {list(data.columns)})")
    if len(data) == 0:
        raise ValueError("data has no rows")


def cell_table(data, dv, within, subject, aggregate=None, levels=None):
    """Subject x level table of ``dv`` (long data: one row per observation) after the checks a
    repeated-measures analysis needs.

    ``within`` is the column of the repeated factor (e.g. the treatment), ``subject`` the column of
    participant ids. Raises ValueError naming the column and row for NaN, non-numeric or infinite
    values, for several rows in a cell unless ``aggregate='mean'`` averages them, for a subject
    missing a level (unbalanced design), and for fewer than 2 subjects or levels. ``levels`` picks
    and orders the levels (default: all, sorted); rows of other levels are an error. In a tidy
    table with ``measure`` and ``value`` columns (:mod:`mutual.study.data`), ``dv`` may name a
    measure (e.g. ``"false_positives"``): its rows are analysed.
    """
    data = _select_measure(data, dv)
    _column_names(data, dv, within, subject)
    for col in (subject, within, dv):
        bad = data[col].isna().to_numpy()
        if bad.any():
            raise ValueError(f"column {col!r} has a missing value (NaN) in row {data.index[bad.argmax()]!r}")
    values = pd.to_numeric(data[dv], errors="coerce")
    bad = values.isna().to_numpy()
    if bad.any():
        i = bad.argmax()
        raise ValueError(f"column {dv!r} must be numeric: row {data.index[i]!r} holds {data[dv].iloc[i]!r}")
    bad = ~np.isfinite(values.to_numpy(dtype=float))
    if bad.any():
        raise ValueError(f"column {dv!r} must hold finite numbers: row {data.index[bad.argmax()]!r} holds "
                         f"{values.iloc[bad.argmax()]!r}")
    if aggregate not in (None, "mean"):
        raise ValueError(f"aggregate must be None or 'mean', got {aggregate!r}")
    d = data[[subject, within]].assign(**{dv: exact_doubles(f"column {dv!r}", values)})
    if levels is not None:
        if isinstance(levels, str) or not hasattr(levels, "__iter__"):
            raise ValueError(f"levels must be a list of the levels of {within!r}, got {levels!r}")
        levels = list(levels)
        if len(set(levels)) != len(levels):
            raise ValueError(f"levels must not repeat a level, got {levels}")
        unknown = sorted(map(str, set(d[within]) - set(levels)))
        if unknown:
            raise ValueError(f"column {within!r} has level(s) {unknown} not among levels={levels}; select the rows first")
        absent = [level for level in levels if level not in set(d[within])]
        if absent:
            raise ValueError(f"level(s) {absent} of levels have no rows in column {within!r}")
    sizes = d.groupby([subject, within]).size()
    if aggregate is None and (sizes > 1).any():
        cell = sizes[sizes > 1].index[0]
        raise ValueError(f"several rows for ({subject}, {within}) = {cell}; pass aggregate='mean' to average them")
    top = float(np.max(np.abs(d[dv]))) if len(d) else 0.0
    e = int(np.frexp(top)[1]) if top > 0 else 0       # means in scaled units: two 1.7e308 average to 1.7e308, not inf
    wide = np.ldexp(d.assign(**{dv: np.ldexp(d[dv].to_numpy(), -e)}).groupby([subject, within])[dv].mean()
                    .unstack(within), e)
    wide = wide.reindex(columns=levels) if levels is not None else wide.reindex(columns=sorted(wide.columns))
    if wide.isna().any().any():
        holes = wide.isna()
        who = list(wide.index[holes.any(axis=1)])
        raise ValueError(f"unbalanced design: subject(s) {who[:5]}{' ...' if len(who) > 5 else ''} miss level(s) "
                         f"{list(wide.columns[holes.any(axis=0)])} of {within!r}; every subject needs every level")
    if wide.shape[0] < 2 or wide.shape[1] < 2:
        raise ValueError(f"need at least 2 subjects and 2 levels of {within!r}, got {wide.shape[0]} subject(s) and "
                         f"{wide.shape[1]} level(s)")
    return wide
