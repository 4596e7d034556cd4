"""Re-deriving published repeated-measures statistics from their summary numbers (Sec. 5.3).

The thesis reports F statistics with their degrees of freedom and the level means of Table 5.1,
not the data. From them: the repeated-measures Tukey p-values of level means with a given error
term (:func:`tukey_from_summary`, also used by :func:`mutual.study.stats.tukey_rm`), the p-value of a reported F (:func:`f_p_value`), the design a one-way
repeated-measures F implies (:func:`design_from_f_dofs`), and the error term and the
repeated-measures Tukey p-values (:func:`recover_from_summary`). These are checks of the thesis's
arithmetic ("consistent"), not reproductions.
"""

from itertools import combinations

import numpy as np
import pandas as pd
from scipy import stats

from ..inputs import check_number
from .errors import DegenerateDataError


def f_p_value(F, df_num, df_den):
    """Upper-tail p-value of an F statistic with (``df_num``, ``df_den``) degrees of freedom."""
    for name, v in (("F", F), ("df_num", df_num), ("df_den", df_den)):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.number)) or not np.isfinite(v):
            raise ValueError(f"{name} must be a finite number, got {v!r}")
    if not (F >= 0 and df_num > 0 and df_den > 0):
        raise ValueError(f"need F >= 0 and positive degrees of freedom, got F={F}, df=({df_num}, {df_den})")
    return float(stats.f.sf(F, df_num, df_den))


def design_from_f_dofs(df_num, df_den):
    """Levels k = df_num + 1 and subjects n = df_den / df_num + 1 of a one-way repeated-measures F."""
    df_num, df_den = check_number("df_num", df_num, low=1, whole=True), check_number("df_den", df_den, low=1, whole=True)
    if df_den % df_num:
        raise ValueError(f"F({df_num}, {df_den}) is not a one-way repeated-measures design "
                         f"(df_den must be a multiple of df_num)")
    return {"levels": df_num + 1, "subjects": df_den // df_num + 1}


def recover_from_summary(means, F, df_num, df_den):
    """Recover the repeated-measures error term and Tukey p-values from published numbers.

    From level means m (k = df_num + 1 of them) and F(df_num, df_den):
    n = df_den / (k-1) + 1 subjects, MS_treatment = n * var(m, ddof=1), MSE =
    MS_treatment / F; then :func:`tukey_from_summary`. Returns dict(n, mse, p, tukey).
    """
    means = dict(means)
    shape = design_from_f_dofs(df_num, df_den)
    if len(means) != shape["levels"]:
        raise ValueError(f"F({df_num}, {df_den}) implies {shape['levels']} levels, got {len(means)} means")
    if isinstance(F, bool) or not isinstance(F, (int, float, np.number)) or not (np.isfinite(F) and F > 0):
        raise ValueError(f"F must be a positive finite number, got {F!r}")
    values = np.array(list(means.values()), dtype=float)
    if not np.isfinite(values).all():
        raise ValueError(f"means must be finite numbers, got {means!r}")
    n = shape["subjects"]
    ms_treatment = n * np.var(values, ddof=1)
    if ms_treatment <= 0:
        raise DegenerateDataError(f"all means are equal ({values[0]:g}): the treatment mean square is 0, so a "
                                  f"positive F = {F} cannot come from them and no error term can be recovered")
    mse = float(ms_treatment / F)
    return {"n": n, "mse": mse, "p": f_p_value(F, df_num, df_den), "tukey": tukey_from_summary(means, mse, n)}


def _level_means(means):
    try:
        means = {level: float(m) for level, m in dict(means).items()}
    except (TypeError, ValueError):
        raise ValueError(f"means must map each level to a number, got {means!r}") from None
    if len(means) < 2:
        raise ValueError(f"means needs at least 2 levels, got {len(means)}")
    bad = [level for level, m in means.items() if not np.isfinite(m)]
    if bad:
        raise ValueError(f"means must be finite numbers; level(s) {bad} are not")
    return means


def tukey_from_summary(means, mse, n):
    """Tukey HSD p-values for all pairs from level means, a repeated-measures MSE and n subjects.

    q = |m_i - m_j| / sqrt(MSE / n); p = P(Q > q) for the studentized range with
    k = len(means) and (k-1)(n-1) degrees of freedom. Returns a DataFrame with
    columns A, B, mean_A, mean_B, diff, q, p.
    """
    means = _level_means(means)
    if isinstance(mse, bool) or not isinstance(mse, (int, float, np.number)) or not (np.isfinite(mse) and mse > 0):
        raise ValueError(f"mse must be a positive finite number, got {mse!r}")
    return tukey_from_root_mse(means, float(np.sqrt(mse)), n)


def tukey_from_root_mse(means, root_mse, n):
    """:func:`tukey_from_summary` from the error term's square root ``sqrt(MSE)`` (representable where MSE
    itself under- or overflows: data in units of 1e-170 or 1e170)."""
    means = _level_means(means)
    k = len(means)
    if not (np.isfinite(root_mse) and root_mse > 0):
        raise ValueError(f"root_mse must be a positive finite number, got {root_mse!r}")
    if isinstance(n, bool) or not (isinstance(n, (int, np.integer)) and n >= 2):
        raise ValueError(f"n must be an integer >= 2 (subjects), got {n!r}")
    df = (k - 1) * (n - 1)
    rows = []
    for a, b in combinations(means, 2):
        diff = means[a] - means[b]
        q = abs(diff) / root_mse * np.sqrt(n)
        rows.append((a, b, means[a], means[b], diff, q, float(stats.studentized_range.sf(q, k, df))))
    return pd.DataFrame(rows, columns=["A", "B", "mean_A", "mean_B", "diff", "q", "p"])


TABLE_5_1_COLUMNS = ["safe_set", "interventions_in_safe_set", "interventions", "predicted_fp_vs_standard",
                     "average_fp", "observed_fp_vs_standard"]


def table_5_1_ratios(table):
    """The arithmetic of Table 5.1 re-derived from its own cells (a DataFrame with
    ``TABLE_5_1_COLUMNS``, one row per safe set, e.g. ``data/ch5_thesis_table_5_1.csv``).

    Returns a dict: ``predicted`` and ``observed`` (per safe set: interventions in the safe set /
    those in the Standard one, and average false positives / the Standard average) and
    ``learned_half`` (the Learned share of all interventions, 1/2 in expectation at alpha = mu).
    """
    missing = [c for c in TABLE_5_1_COLUMNS if c not in getattr(table, "columns", [])]
    if missing:
        raise ValueError(f"table must be a DataFrame with columns {TABLE_5_1_COLUMNS}; missing {missing}")
    t = table.set_index("safe_set")
    for name in ("Standard", "Learned"):
        if name not in t.index:
            raise ValueError(f"table has no row for the {name!r} safe set")
    numbers = t[TABLE_5_1_COLUMNS[1:]].apply(lambda col: np.asarray(col, dtype=float))
    if not np.isfinite(numbers.to_numpy()).all() or (numbers.to_numpy() < 0).any():
        raise ValueError("table must hold non-negative finite numbers")
    std = numbers.loc["Standard"]
    if std["interventions_in_safe_set"] <= 0 or std["average_fp"] <= 0:
        raise ValueError("the Standard row must have positive interventions in its safe set and false positives")
    return {"predicted": (numbers["interventions_in_safe_set"] / std["interventions_in_safe_set"]).to_dict(),
            "observed": (numbers["average_fp"] / std["average_fp"]).to_dict(),
            "learned_half": float(numbers.loc["Learned", "interventions_in_safe_set"]
                                  / numbers.loc["Learned", "interventions"])}


def rounding_range(means, F, df_num, df_den, decimals=2):
    """How much rounding can move the recovered Tukey p-values: :func:`recover_from_summary` at every
    corner of the box of means and F within half a unit of their last reported ``decimals``.

    Returns a DataFrame with columns A, B, p (at the reported numbers), p_low and p_high.
    """
    if isinstance(decimals, bool) or not isinstance(decimals, (int, np.integer)) or not 0 <= decimals <= 10:
        raise ValueError(f"decimals must be a whole number in 0..10, got {decimals!r}")
    means = dict(means)
    half = 0.5 * 10.0 ** -decimals
    centre = recover_from_summary(means, F, df_num, df_den)["tukey"]
    corners = []
    for signs in np.array(np.meshgrid(*[[-1, 1]] * (len(means) + 1))).reshape(len(means) + 1, -1).T:
        moved = {level: m + half * s for (level, m), s in zip(means.items(), signs[:-1])}
        corners.append(recover_from_summary(moved, F + half * signs[-1], df_num, df_den)["tukey"]["p"].to_numpy())
    corners = np.array(corners)
    return centre[["A", "B", "p"]].assign(p_low=corners.min(axis=0), p_high=corners.max(axis=0))
