"""Intervals for means over seeds: percentile bootstrap (scipy.stats.bootstrap) or Student t."""

import numpy as np
from scipy import stats

METHODS = ("bootstrap", "t")


def mean_interval(values, level=0.95, method="bootstrap", n_resamples=2000, seed=0):
    """``(mean, low, high)`` of ``values`` (1-D, NaN dropped) with a ``level`` interval for the mean:
    the percentile bootstrap over the values (``method="bootstrap"``, ``n_resamples`` resamples from
    generator ``seed``) or the Student t interval (``method="t"``). A single value, or identical
    values, give a zero-width interval; no values give NaNs."""
    if method not in METHODS:
        raise ValueError(f"method: must be one of {METHODS}, got {method!r}")
    if not 0 < level < 1:
        raise ValueError(f"level: must lie in (0, 1), got {level!r}")
    v = np.asarray(values, dtype=float).ravel()
    v = v[~np.isnan(v)]
    if v.size == 0:
        return np.nan, np.nan, np.nan
    mean = float(v.mean())
    if v.size == 1 or np.all(v == v[0]):
        return mean, mean, mean
    if method == "t":
        half = stats.t.ppf(0.5 + level / 2, v.size - 1) * v.std(ddof=1) / np.sqrt(v.size)
        return mean, mean - half, mean + half
    res = stats.bootstrap((v,), np.mean, confidence_level=level, n_resamples=n_resamples, method="percentile",
                          random_state=np.random.default_rng(seed))
    return mean, float(res.confidence_interval.low), float(res.confidence_interval.high)


def summarise(frame, by, columns, level=0.95, method="bootstrap"):
    """Mean and interval of each of ``columns`` per group ``by`` of a DataFrame: columns
    ``<c>``, ``<c>_low``, ``<c>_high`` and the number of values ``n``."""
    import pandas as pd

    rows = []
    for key, group in frame.groupby(by, sort=True):
        row = {by: key, "n": len(group)}
        for c in columns:
            row[c], row[f"{c}_low"], row[f"{c}_high"] = mean_interval(group[c], level, method)
        rows.append(row)
    return pd.DataFrame(rows)
