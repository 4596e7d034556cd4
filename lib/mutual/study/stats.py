"""Statistics of the chapter 5 user study (sections 5.3.1-5.3.2).

* One-way repeated-measures ANOVA (statsmodels ``AnovaRM``) after explicit checks
  of balance, duplicates and NaN (``AnovaRM`` silently returns NaN on a NaN
  outcome), with the repeated-measures error term MSE and the Greenhouse-Geisser
  epsilon and corrected p-value.
* All-pairs post-hoc Tukey HSD with the repeated-measures error term,
  q = |mean_i - mean_j| / sqrt(MSE / n), p from the studentized range
  distribution with k groups and (k-1)(n-1) degrees of freedom; paired t-tests
  with Holm's correction as a robustness check.
* The one-sample t-test of a Likert answer against the scale's neutral point.
* Recovering the error term and Tukey p-values from published summary numbers
  (group means and F), to check the thesis's own statistics.
"""

from dataclasses import dataclass
from itertools import combinations

import numpy as np
import pandas as pd
from scipy import stats
from statsmodels.stats.anova import AnovaRM
from statsmodels.stats.multitest import multipletests

from .data import LIKERT_RANGE


@dataclass(frozen=True)
class RMAnova:
    """Result of :func:`rm_anova`. ``cells`` is the subject x level table of the analysed values."""
    F: float
    df_num: int
    df_den: int
    p: float
    mse: float
    epsilon_gg: float
    p_gg: float
    n_subjects: int
    levels: tuple
    means: dict
    cells: pd.DataFrame


def cell_table(data, dv, subject, within, aggregate=None, levels=None):
    """Subject x level table of ``dv`` after the checks a repeated-measures analysis needs.

    Raises ValueError for missing columns, NaN in ``dv``/``subject``/``within``,
    several rows in a cell unless ``aggregate`` ('mean') is given, a subject
    missing a level (unbalanced design), or fewer than 2 subjects or levels.
    ``levels`` fixes the column order (default: sorted).
    """
    if not isinstance(data, pd.DataFrame):
        raise ValueError(f"data must be a pandas DataFrame, got {type(data).__name__}")
    missing = [c for c in (dv, subject, within) if c not in data.columns]
    if missing:
        raise ValueError(f"data is missing columns {missing}")
    nan_cols = [c for c in (dv, subject, within) if data[c].isna().any()]
    if nan_cols:
        raise ValueError(f"data has NaN in columns {nan_cols}; AnovaRM would silently return NaN")
    values = pd.to_numeric(data[dv], errors="coerce")
    if values.isna().any():
        raise ValueError(f"column {dv!r} must be numeric")
    if aggregate not in (None, "mean"):
        raise ValueError(f"aggregate must be None or 'mean', got {aggregate!r}")
    d = data[[subject, within]].assign(**{dv: values})
    sizes = d.groupby([subject, within]).size()
    if aggregate is None and (sizes > 1).any():
        cell = sizes[sizes > 1].index[0]
        raise ValueError(f"duplicate rows for ({subject}, {within}) = {cell}; pass aggregate='mean' to average them")
    wide = d.groupby([subject, within])[dv].mean().unstack(within)
    if levels is not None:
        unknown = sorted(set(wide.columns) - set(levels))
        if unknown:
            raise ValueError(f"unknown {within} level(s) {unknown}; expected {list(levels)}")
        wide = wide.reindex(columns=list(levels))
    if wide.isna().any().any():
        holes = wide.isna()
        who = holes.any(axis=1)
        raise ValueError(f"unbalanced design: subject(s) {list(wide.index[who])} miss level(s) "
                         f"{sorted(set(wide.columns[holes.any(axis=0)]))}")
    if wide.shape[0] < 2 or wide.shape[1] < 2:
        raise ValueError(f"need at least 2 subjects and 2 levels, got {wide.shape[0]} and {wide.shape[1]}")
    return wide


def greenhouse_geisser_epsilon(wide):
    """Greenhouse-Geisser epsilon from the double-centred covariance of a subject x level table."""
    y = np.asarray(wide, dtype=float)
    k = y.shape[1]
    s = np.cov(y, rowvar=False)
    c = np.eye(k) - 1.0 / k
    sdc = c @ s @ c
    denom = (k - 1) * np.sum(sdc ** 2)
    return float(np.trace(sdc) ** 2 / denom) if denom > 0 else 1.0


def rm_anova(data, dv, subject, within, aggregate=None, levels=None):
    """One-way repeated-measures ANOVA of ``dv`` over ``within`` (section 5.3.1).

    F, df and p come from statsmodels ``AnovaRM`` on the checked cell table
    (:func:`cell_table`); MSE = SS_error / ((k-1)(n-1)) and the Greenhouse-Geisser
    corrected p use the same table.
    """
    wide = cell_table(data, dv, subject, within, aggregate, levels)
    long = wide.stack().rename("y").reset_index()
    long.columns = ["subject", "level", "y"]
    table = AnovaRM(long, "y", "subject", within=["level"]).fit().anova_table.iloc[0]
    n, k = wide.shape
    y = wide.to_numpy(dtype=float)
    resid = y - y.mean(axis=1, keepdims=True) - y.mean(axis=0, keepdims=True) + y.mean()
    df_num, df_den = k - 1, (k - 1) * (n - 1)
    mse = float(np.sum(resid ** 2) / df_den)
    eps = greenhouse_geisser_epsilon(wide)
    F = float(table["F Value"])
    return RMAnova(F=F, df_num=int(table["Num DF"]), df_den=int(table["Den DF"]), p=float(table["Pr > F"]),
                   mse=mse, epsilon_gg=eps, p_gg=float(stats.f.sf(F, eps * df_num, eps * df_den)),
                   n_subjects=n, levels=tuple(wide.columns), means=dict(wide.mean()), cells=wide)


def tukey_from_summary(means, mse, n):
    """Tukey HSD p-values for all pairs from level means, a repeated-measures MSE and n subjects.

    q = |m_i - m_j| / sqrt(MSE / n); p = P(Q > q) for the studentized range with
    k = len(means) and (k-1)(n-1) degrees of freedom. Returns a DataFrame with
    columns A, B, mean_A, mean_B, diff, q, p.
    """
    means = dict(means)
    k = len(means)
    if k < 2:
        raise ValueError(f"means needs at least 2 levels, got {k}")
    if not (np.isfinite(mse) and mse > 0):
        raise ValueError(f"mse must be a positive number, got {mse!r}")
    if not (isinstance(n, (int, np.integer)) and n >= 2):
        raise ValueError(f"n must be an integer >= 2, got {n!r}")
    df = (k - 1) * (n - 1)
    rows = []
    for a, b in combinations(means, 2):
        diff = means[a] - means[b]
        q = abs(diff) / np.sqrt(mse / n)
        rows.append((a, b, means[a], means[b], diff, q, float(stats.studentized_range.sf(q, k, df))))
    return pd.DataFrame(rows, columns=["A", "B", "mean_A", "mean_B", "diff", "q", "p"])


def tukey_rm(anova):
    """All-pairs Tukey HSD with the repeated-measures error term of an :class:`RMAnova`."""
    return tukey_from_summary(anova.means, anova.mse, anova.n_subjects)


def paired_t_holm(cells):
    """Paired t-tests between all pairs of columns of a subject x level table, Holm-corrected.

    Returns a DataFrame with columns A, B, t, df, p, p_holm.
    """
    cells = pd.DataFrame(cells)
    if cells.isna().any().any() or cells.shape[1] < 2 or cells.shape[0] < 2:
        raise ValueError("cells must be a complete subject x level table with >= 2 subjects and levels")
    rows = []
    for a, b in combinations(cells.columns, 2):
        res = stats.ttest_rel(cells[a], cells[b])
        rows.append((a, b, float(res.statistic), int(res.df), float(res.pvalue)))
    out = pd.DataFrame(rows, columns=["A", "B", "t", "df", "p"])
    out["p_holm"] = multipletests(out["p"], method="holm")[1]
    return out


def likert_vs_neutral(answers, neutral=4.0):
    """One-sample t-test of Likert answers against the neutral point (section 5.3.2).

    Answers must be whole numbers in 1..7. Returns dict(mean, t, df, p, n).
    """
    a = np.asarray(answers, dtype=float)
    lo, hi = LIKERT_RANGE
    if a.ndim != 1 or a.size < 2:
        raise ValueError(f"answers must be a 1-D sequence of at least 2 answers, got shape {a.shape}")
    if not np.isfinite(a).all() or ((a < lo) | (a > hi)).any() or not np.allclose(a, np.round(a)):
        raise ValueError(f"answers must be whole numbers in {lo}..{hi}")
    res = stats.ttest_1samp(a, neutral)
    return {"mean": float(a.mean()), "t": float(res.statistic), "df": int(a.size - 1),
            "p": float(res.pvalue), "n": int(a.size)}


def f_p_value(F, df_num, df_den):
    """Upper-tail p-value of an F statistic."""
    if not (F >= 0 and df_num > 0 and df_den > 0):
        raise ValueError(f"need F >= 0 and positive degrees of freedom, got F={F}, df=({df_num}, {df_den})")
    return float(stats.f.sf(F, df_num, df_den))


def design_from_f_dofs(df_num, df_den):
    """Levels k = df_num + 1 and subjects n = df_den / df_num + 1 of a one-way repeated-measures F."""
    n = df_den / df_num + 1
    if not float(n).is_integer():
        raise ValueError(f"F({df_num}, {df_den}) is not a one-way repeated-measures design")
    return {"levels": int(df_num + 1), "subjects": int(n)}


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
    if not F > 0:
        raise ValueError(f"F must be positive, got {F!r}")
    n = shape["subjects"]
    ms_treatment = n * np.var(list(means.values()), ddof=1)
    mse = float(ms_treatment / F)
    return {"n": n, "mse": mse, "p": f_p_value(F, df_num, df_den), "tukey": tukey_from_summary(means, mse, n)}


def significance_stars(p):
    """'***' (p < .001), '**' (< .01), '*' (< .05) or 'n.s.'."""
    return "***" if p < 0.001 else "**" if p < 0.01 else "*" if p < 0.05 else "n.s."


def plot_condition_means(ax, anova, tukey, colors=None):
    """Fig. 5.4: the mean of each level with standard-error bars and Tukey significance brackets."""
    levels = list(anova.levels)
    cells = anova.cells[levels]
    means, se = cells.mean(), cells.std(ddof=1) / np.sqrt(len(cells))
    x = np.arange(len(levels))
    ax.bar(x, means, yerr=se, capsize=4, color=colors or None, alpha=0.85)
    ax.set_xticks(x, levels)
    top = float((means + se).max())
    step = 0.09 * top if top > 0 else 0.1
    for i, row in enumerate(tukey.itertuples()):
        a, b = levels.index(row.A), levels.index(row.B)
        y = top + step * (i + 1)
        ax.plot([a, a, b, b], [y - step * 0.3, y, y, y - step * 0.3], color="black", lw=0.8)
        ax.text((a + b) / 2, y, f"{significance_stars(row.p)} (p={row.p:.3g})", ha="center", va="bottom", fontsize=7)
    ax.set_ylim(0, top + step * (len(tukey) + 1.2))
    return ax
