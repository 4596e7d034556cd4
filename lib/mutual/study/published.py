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


def _table_numbers(table):
    """Table 5.1's numeric cells indexed by safe set, checked (``TABLE_5_1_COLUMNS``, Standard and Learned rows)."""
    missing = [c for c in TABLE_5_1_COLUMNS if c not in getattr(table, "columns", [])]
    if missing:
        raise ValueError(f"table must be a DataFrame with columns {TABLE_5_1_COLUMNS}; missing {missing}")
    t = table.set_index("safe_set")
    for name in ("Standard", "Learned"):
        if name not in t.index:
            raise ValueError(f"table has no row for the {name!r} safe set")
    try:
        numbers = t[TABLE_5_1_COLUMNS[1:]].apply(lambda col: np.asarray(col, dtype=float))
    except (TypeError, ValueError):
        raise ValueError("table must hold non-negative finite numbers") from None
    if not np.isfinite(numbers.to_numpy()).all() or (numbers.to_numpy() < 0).any():
        raise ValueError("table must hold non-negative finite numbers")
    std = numbers.loc["Standard"]
    if std["interventions_in_safe_set"] <= 0 or std["average_fp"] <= 0:
        raise ValueError("the Standard row must have positive interventions in its safe set and false positives")
    return numbers


def table_5_1_ratios(table):
    """The arithmetic of Table 5.1 re-derived from its own cells (a DataFrame with
    ``TABLE_5_1_COLUMNS``, one row per safe set, e.g. ``data/ch5_thesis_table_5_1.csv``).

    Returns a dict: ``predicted`` and ``observed`` (per safe set: interventions in the safe set /
    those in the Standard one, and average false positives / the Standard average) and
    ``learned_half`` (the Learned share of all interventions, 1/2 in expectation at alpha = mu).
    """
    numbers = _table_numbers(table)
    std = numbers.loc["Standard"]
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


def prediction_agreement(table, F, df_num, df_den, z=2.0):
    """Whether Table 5.1's observed false positives agree with those predicted from Phase II (Sec. 5.3.3,
    line 1030), judged from the table's own numbers and the reported F of the false-positive ANOVA.

    For each safe set but Standard: the predicted ratio ``p`` (Phase II interventions in its safe set over those
    in the Standard one) and the observed ratio ``o`` (its average false positives over Standard's). ``p`` is a
    share of the interventions in the Standard safe set (the Learned and Conservative safe sets lie inside it:
    the exclusion rule, a doubled obstacle), standard error ``sqrt(p (1 - p) / I_std)``; ``o`` is a ratio of level
    means, standard error by the delta method with the repeated-measures error term recovered from F
    (:func:`recover_from_summary`), ``sqrt(MSE / n (1 + o^2)) / mean_std``. The between-participant variance,
    which the thesis does not report, would only widen ``o``'s spread, so this tolerance is a lower bound and
    the check is harder to pass, not easier. They agree when ``|p - o| <= z sqrt(se_p^2 + se_o^2)`` for every
    safe set, the predicted and observed ratios fall in the same order, and each tolerance is narrower than
    the predicted decrease ``1 - p`` (else the check could not tell that decrease from none).

    Returns ``(agree, rows)``: a bool and a DataFrame with columns safe_set, predicted, observed, se_predicted,
    se_observed, tolerance, decrease, within.
    """
    if isinstance(z, bool) or not isinstance(z, (int, float, np.number)) or not (np.isfinite(z) and z > 0):
        raise ValueError(f"z must be a positive finite number, got {z!r}")
    numbers = _table_numbers(table)
    std = numbers.loc["Standard"]
    recovered = recover_from_summary(numbers["average_fp"].to_dict(), F, df_num, df_den)
    spread = np.sqrt(recovered["mse"] / recovered["n"])
    others = numbers.drop(index="Standard")
    predicted = others["interventions_in_safe_set"] / std["interventions_in_safe_set"]
    observed = others["average_fp"] / std["average_fp"]
    if (predicted > 1).any():
        raise ValueError("table: a safe set holds more interventions than the Standard one, which contains it")
    rows = pd.DataFrame({"safe_set": others.index, "predicted": predicted.to_numpy(), "observed": observed.to_numpy(),
                         "se_predicted": np.sqrt(predicted * (1 - predicted) / std["interventions_in_safe_set"]).to_numpy(),
                         "se_observed": (spread * np.sqrt(1 + observed ** 2) / std["average_fp"]).to_numpy()})
    rows["tolerance"] = z * np.hypot(rows["se_predicted"], rows["se_observed"])
    rows["decrease"] = 1 - rows["predicted"]
    rows["within"] = (rows["predicted"] - rows["observed"]).abs() <= rows["tolerance"]
    same_order = bool(np.array_equal(np.argsort(rows["predicted"].to_numpy(), kind="stable"),
                                     np.argsort(rows["observed"].to_numpy(), kind="stable")))
    agree = bool(rows["within"].all() and same_order and (rows["tolerance"] < rows["decrease"]).all())
    return agree, rows


def arcs_against_clusters(shorter, analysed, clusters, standard_like="standard-like"):
    """Lines 1010 and 1024 side by side: ``shorter`` of the ``analysed`` participants' Learned safe sets had
    shorter avoidance arcs than the Conservative set, and Fig. 5.5 sorts the same sets into ``clusters``
    (``{name: count}``). The counts fit together when the clusters hold every analysed participant and the
    ``standard_like`` sets (arcing like the Standard set, whose arc is shorter than the Conservative one) are
    among the shorter ones, ``standard_like <= shorter``.

    Returns a dict: ``consistent``, ``not_shorter`` (``analysed - shorter``) and, per other cluster, how many
    of its sets must still arc shorter than the Conservative set (``at_least_shorter``: its size less the sets
    that are not shorter, at least 0).
    """
    counts = {"shorter": shorter, "analysed": analysed, **{f"clusters[{k!r}]": v for k, v in dict(clusters).items()}}
    for name, n in counts.items():
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"{name} must be a whole number >= 0, got {n!r}")
    if shorter > analysed:
        raise ValueError(f"shorter ({shorter}) counts some of the analysed participants ({analysed}): at most that many")
    clusters = dict(clusters)
    if standard_like not in clusters:
        raise ValueError(f"clusters has no {standard_like!r} cluster, got {sorted(clusters)}")
    not_shorter = analysed - shorter
    consistent = sum(clusters.values()) == analysed and clusters[standard_like] <= shorter
    return {"consistent": bool(consistent), "not_shorter": int(not_shorter),
            "at_least_shorter": {k: int(max(0, v - not_shorter)) for k, v in clusters.items() if k != standard_like}}
