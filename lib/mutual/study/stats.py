"""Statistics of the chapter 5 user study (sections 5.3.1-5.3.2), in the words of a study's data.

* :func:`rm_anova` ``(data, dv, within, subject)``: the one-way repeated-measures ANOVA from the
  sums of squares of the checked subject x level table (:func:`cell_table`), with the
  repeated-measures error term MSE, the Greenhouse-Geisser epsilon and corrected p.
* :func:`tukey_rm`: all-pairs Tukey HSD with the repeated-measures error term,
  q = |mean_i - mean_j| / sqrt(MSE / n), p from the studentized range with k levels and
  (k-1)(n-1) degrees of freedom; :func:`paired_t_holm`: paired t-tests, Holm-corrected.
* :func:`likert_vs_neutral`: the one-sample t-test of Likert answers against the neutral point.
* the thesis's own statistics, re-derived from its published numbers, are in :mod:`.published`
  (Tukey from summary numbers, ``f_p_value``, ``design_from_f_dofs``, ``recover_from_summary``;
  importable from here too).

Degenerate data. A statistic that the data leave undefined raises :class:`DegenerateDataError`
(a ``ValueError``) that names the measure and the reason; nothing here returns NaN, an infinite
statistic or a negative F. As R's ``t.test`` and ``aov`` do, we refuse rather than guess:

* no within-subject variation at all (e.g. a measure that is 0 in every trial, or one constant per
  subject): the ANOVA's F is 0/0;
* zero residual variance (every subject shows exactly the same differences between levels): F is
  infinite;
* a pair of levels whose paired differences are all the same (identical columns included), or
  Likert answers that are all equal: the t statistic is 0/0 or infinite (:func:`paired_t_holm` with
  ``undefined="leave"`` leaves such a pair's t NaN and names the reason, and tests the other pairs).

Numbers count as equal when they agree to about 13 significant digits of the data's magnitude.
"""

from dataclasses import dataclass, field
from itertools import combinations

import numpy as np
import pandas as pd
from scipy import stats

from .. import budget
from .cells import cell_table
from .data import LIKERT_RANGE
from .errors import DegenerateDataError
from .published import (design_from_f_dofs, f_p_value, recover_from_summary, tukey_from_root_mse,  # noqa: F401
                        tukey_from_summary)

_RELATIVE_ZERO = 1e-13


def _negligible(sum_of_squares, values):
    """Whether a sum of squares over ``values`` is zero up to rounding at the data's magnitude."""
    v = np.asarray(values, dtype=float)
    scale = float(np.max(np.abs(v))) if v.size else 0.0
    return sum_of_squares <= v.size * (_RELATIVE_ZERO * scale) ** 2


def _ldexp_quiet(x, e):
    """``x 2^e``, inf or 0 without a warning where that is beyond the range of doubles (reported as such)."""
    with np.errstate(over="ignore", under="ignore"):
        return np.ldexp(x, e)


def _exponent(values):
    """``e`` with ``max |values| 2^-e`` in [0.5, 1) (0 for all-zero values): dividing by ``2^e`` is exact, and
    squares of the scaled values neither underflow nor overflow, whatever the data's units (1e-170 or 1e170)."""
    top = float(np.max(np.abs(values)))
    return int(np.frexp(top)[1]) if top > 0 else 0


@dataclass(frozen=True, repr=False)
class RMAnova:
    """Result of :func:`rm_anova`.

    ``F`` with ``df1 = k - 1`` and ``df2 = (k - 1)(n - 1)`` degrees of freedom, its ``p``, the
    repeated-measures error term ``mse``, the Greenhouse-Geisser ``eps`` and corrected ``p_gg``;
    ``levels``, their ``means``, ``n_subjects``, and ``cells`` (the subject x level table that was
    analysed). The sums of squares ``ss_effect``, ``ss_error`` and ``ss_subjects`` (between subjects),
    the mean squares ``ms_effect`` and ``ms_error`` (= ``mse``), the partial eta squared
    ``SS_effect / (SS_effect + SS_error)`` and the generalized eta squared
    ``SS_effect / (SS_effect + SS_subjects + SS_error)`` (Olejnik and Algina 2003; Bakeman 2005) are
    those of pingouin's ``rm_anova``. ``to_dict()`` gives the numbers as plain JSON-ready values.
    """
    F: float
    df1: int
    df2: int
    p: float
    mse: float
    eps: float
    p_gg: float
    n_subjects: int
    levels: tuple
    means: dict
    cells: pd.DataFrame = field(compare=False)
    dv: str = "value"
    within: str = "level"
    subject: str = "subject"
    ss_effect: float = 0.0
    ss_error: float = 0.0
    ss_subjects: float = 0.0
    eta2p: float = 0.0
    eta2g: float = 0.0
    root_mse: float = 0.0

    @property
    def ms_effect(self):
        return self.ss_effect / self.df1

    @property
    def ms_error(self):
        return self.mse

    def standard_errors(self):
        """The standard error of each level's mean over subjects (``sd / sqrt(n)``), each level computed in its own
        scaled units (a huge value in one level leaves the others' digits alone)."""
        y = self.cells.to_numpy(dtype=float)
        sd = [float(_ldexp_quiet(np.ldexp(c, -_exponent(c)).std(ddof=1), _exponent(c))) for c in y.T]
        return {level: v / np.sqrt(len(y)) for level, v in zip(self.levels, sd)}

    # the names of earlier versions (statsmodels' words)
    @property
    def df_num(self):
        return self.df1

    @property
    def df_den(self):
        return self.df2

    @property
    def epsilon_gg(self):
        return self.eps

    def to_dict(self):
        """The result as plain values: ``F, df1, df2, p, eps, p_gg, mse, n, levels, means, dv, within, subject``,
        the sums and mean squares and both eta squared."""
        return {"dv": str(self.dv), "within": str(self.within), "subject": str(self.subject),
                "n": int(self.n_subjects), "levels": [str(level) for level in self.levels],
                "means": {str(level): float(m) for level, m in self.means.items()},
                "F": float(self.F), "df1": int(self.df1), "df2": int(self.df2), "p": float(self.p),
                "eps": float(self.eps), "p_gg": float(self.p_gg), "mse": float(self.mse),
                "ss_effect": float(self.ss_effect), "ss_error": float(self.ss_error),
                "ss_subjects": float(self.ss_subjects), "ms_effect": float(self.ms_effect),
                "eta2p": float(self.eta2p), "eta2g": float(self.eta2g)}

    def __repr__(self):
        means = ", ".join(f"{level}={m:.4g}" for level, m in self.means.items())
        return (f"RMAnova({self.dv} ~ {self.within} | {self.subject}: F({self.df1}, {self.df2}) = {self.F:.4g}, "
                f"p = {self.p:.3g}, GG eps = {self.eps:.3f}, p_GG = {self.p_gg:.3g}, n = {self.n_subjects}; "
                f"means {means})")


def _distinct_levels(columns):
    """Refuse a wide table whose level columns repeat a name (a pair would be tested twice, or with itself)."""
    from ..inputs import check_names
    seen = set()
    for name in columns:
        if name in seen:
            raise ValueError(f"cells: the level column {name!r} appears twice; each level needs one column")
        seen.add(name)
    check_names(list(columns), "levels", "cells", row=lambda i: f"column {i + 1}")


def greenhouse_geisser_epsilon(cells):
    """Greenhouse-Geisser epsilon of a subject x level table, from its double-centred covariance S:
    ``tr(S)^2 / ((k-1) sum S_ij^2)``, in ``[1/(k-1), 1]``; 1 when S is zero."""
    if isinstance(cells, pd.DataFrame):
        _distinct_levels(cells.columns)
    y = np.asarray(cells, dtype=float)
    if y.ndim != 2 or y.shape[0] < 2 or y.shape[1] < 2 or not np.isfinite(y).all():
        raise ValueError(f"cells must be a finite subject x level table with >= 2 rows and columns, got shape {y.shape}")
    k = y.shape[1]
    y = y - y.mean(axis=0)
    y = np.ldexp(y, -_exponent(y))        # epsilon is scale-free: the squares of S neither underflow nor overflow
    c = np.eye(k) - 1.0 / k
    sdc = c @ np.cov(y, rowvar=False) @ c
    denom = (k - 1) * np.sum(sdc ** 2)
    if denom <= 0:
        return 1.0
    return float(np.clip(np.trace(sdc) ** 2 / denom, 1.0 / (k - 1), 1.0))


def _anova_of_cells(wide, dv, within, subject):
    raw = wide.to_numpy(dtype=float)
    n, k = raw.shape
    e = _exponent(raw)
    y = np.ldexp(raw, -e)                 # exact; sums of squares in these units, reported in the data's
    grand = y.mean()
    row, col = y.mean(axis=1, keepdims=True), y.mean(axis=0, keepdims=True)
    ss_within = float(np.sum((y - row) ** 2))
    ss_effect = float(n * np.sum((col - grand) ** 2))
    ss_error = float(np.sum((y - row - col + grand) ** 2))
    ss_subjects = float(k * np.sum((row - grand) ** 2))
    if _negligible(ss_within, y):
        what = f"every value is {raw.flat[0]:g}" if np.all(raw == raw.flat[0]) else \
            f"every subject has one value at every level of {within!r}" if np.all(raw == raw[:, :1]) else \
            f"its values differ within subjects by less than 1e-13 of the largest, {np.max(np.abs(raw)):.6g}: too " \
            "little to tell from rounding"
        raise DegenerateDataError(f"{dv!r} does not vary within subjects ({what}): the repeated-measures F is 0/0, "
                                  "so there is nothing to test")
    if _negligible(ss_error, y):
        raise DegenerateDataError(
            f"{dv!r} has zero residual variance: every subject shows exactly the same differences between the levels "
            f"of {within!r}, so the repeated-measures F is infinite; report the differences themselves")
    if _negligible(ss_effect, y):
        ss_effect = 0.0
    df1, df2 = k - 1, (k - 1) * (n - 1)
    F = (ss_effect / df1) / (ss_error / df2)
    eps = greenhouse_geisser_epsilon(y)
    unscaled = lambda ss: float(_ldexp_quiet(ss, 2 * e))
    return RMAnova(F=float(F), df1=df1, df2=df2, p=float(stats.f.sf(F, df1, df2)), mse=unscaled(ss_error / df2),
                   eps=eps, p_gg=float(stats.f.sf(F, eps * df1, eps * df2)), n_subjects=n, levels=tuple(wide.columns),
                   means={c: float(np.ldexp(m, e)) for c, m in zip(wide.columns, col.ravel())}, cells=wide, dv=dv,
                   within=within, subject=subject, ss_effect=unscaled(ss_effect), ss_error=unscaled(ss_error),
                   ss_subjects=unscaled(ss_subjects), eta2p=ss_effect / (ss_effect + ss_error),
                   eta2g=ss_effect / (ss_effect + ss_subjects + ss_error),
                   root_mse=float(np.ldexp(np.sqrt(ss_error / df2), e)))


def rm_anova(data, dv, within, subject, aggregate=None, levels=None):
    """One-way repeated-measures ANOVA of ``dv`` over the levels of ``within`` (section 5.3.1).

    ``data``: long format, one row per observation, with columns ``dv`` (numbers), ``within`` (the
    level, e.g. the treatment; any names) and ``subject`` (participant ids); ``aggregate='mean'``
    averages repeated rows of a cell (e.g. two trials per treatment). From the checked cell table
    (:func:`cell_table`): ``SS_effect = n sum_j (m_j - m)^2``, ``SS_error`` the subject x level
    interaction, ``F = (SS_effect / (k-1)) / (SS_error / ((k-1)(n-1)))``, p from the F
    distribution; the Greenhouse-Geisser correction scales both degrees of freedom by ``eps``.
    Raises :class:`DegenerateDataError` when F is undefined (module docstring). Returns an
    :class:`RMAnova`.
    """
    return _anova_of_cells(cell_table(data, dv, within, subject, aggregate, levels), dv, within, subject)


def _anova_from(data, dv, within, subject, aggregate, levels):
    if isinstance(data, RMAnova):
        return data
    if dv is None or within is None or subject is None:
        raise ValueError("pass an RMAnova, or long data with dv, within and subject column names")
    return rm_anova(data, dv, within, subject, aggregate, levels)


def _check_pairs(levels, subjects, allow_large):
    """Refuse, before any pair is tested, all pairs of more levels than the limits allow (:mod:`mutual.budget`)."""
    budget.check(budget.anova(levels, subjects), allow_large)


def tukey_rm(anova, dv=None, within=None, subject=None, aggregate=None, levels=None, allow_large=None):
    """All-pairs Tukey HSD with the repeated-measures error term of an :class:`RMAnova` (or of
    ``rm_anova(anova, dv, within, subject, ...)`` when given long data). Columns A, B, mean_A,
    mean_B, diff, q, p. ``allow_large``: as :func:`mutual.budget.check` (k levels are k (k-1) / 2 pairs)."""
    res = _anova_from(anova, dv, within, subject, aggregate, levels)
    _check_pairs(len(res.levels), res.n_subjects, allow_large)
    if res.root_mse > 0:                  # the error term's root, exact at any scale (mse may underflow)
        return tukey_from_root_mse(res.means, res.root_mse, res.n_subjects)
    return tukey_from_summary(res.means, res.mse, res.n_subjects)


def paired_t_holm(cells, dv=None, within=None, subject=None, aggregate=None, levels=None, allow_large=None,
                  undefined="raise"):
    """Paired t-tests between all pairs of levels, Holm-corrected.

    ``cells``: a subject x level table (wide), an :class:`RMAnova` (its cells), or long data with
    ``dv``, ``within`` and ``subject`` named (as :func:`rm_anova`). Returns a DataFrame with
    columns A, B, mean_diff, t, df, p, p_holm. A pair whose differences are all equal (identical
    levels included) has no defined t: :class:`DegenerateDataError` names the pair (``undefined="raise"``),
    or (``undefined="leave"``) its t, p and p_holm are NaN, its reason is in ``out.attrs["undefined"]``
    (``{(A, B): reason}``), and Holm's correction runs over the pairs that have a t. ``allow_large``: as
    :func:`tukey_rm`.
    """
    if undefined not in ("raise", "leave"):
        raise ValueError(f"undefined must be 'raise' or 'leave', got {undefined!r}")
    wide = _wide_cells(cells, dv, within, subject, aggregate, levels)
    y = wide.to_numpy(dtype=float)
    _check_pairs(y.shape[1], y.shape[0], allow_large)
    rows, reasons = [], {}
    for (i, a), (j, b) in combinations(enumerate(wide.columns), 2):
        e = _exponent(y[:, [i, j]])       # each pair in its own units: t is scale-free, and a huge value in another
        z = np.ldexp(y[:, [i, j]], -e)    # level leaves this pair's digits alone (1e-170 or 1e170 alike)
        d = z[:, 0] - z[:, 1]
        why = _constant_differences(d, z, e, y[:, [i, j]])
        if why is not None:
            if undefined == "raise":
                raise DegenerateDataError(f"levels {a!r} and {b!r}: {why}")
            reasons[(a, b)] = why
            rows.append((a, b, float(_ldexp_quiet(d.mean(), e)), np.nan, len(d) - 1, np.nan))
            continue
        res = stats.ttest_rel(z[:, 0], z[:, 1])
        rows.append((a, b, float(_ldexp_quiet(d.mean(), e)), float(res.statistic), int(res.df), float(res.pvalue)))
    out = pd.DataFrame(rows, columns=["A", "B", "mean_diff", "t", "df", "p"])
    defined = out["p"].notna().to_numpy()
    out["p_holm"] = np.nan
    out.loc[defined, "p_holm"] = holm(out["p"].to_numpy()[defined])
    out.attrs["undefined"] = reasons
    return out


def _wide_cells(cells, dv, within, subject, aggregate, levels):
    """The checked subject x level table of :func:`paired_t_holm`'s ``cells``."""
    if isinstance(cells, RMAnova):
        wide = cells.cells
    elif dv is not None or within is not None or subject is not None:
        wide = _anova_from(cells, dv, within, subject, aggregate, levels).cells
    else:
        if not isinstance(cells, pd.DataFrame):
            raise ValueError(f"cells must be a subject x level DataFrame, an RMAnova or long data, got "
                             f"{type(cells).__name__}")
        wide = cells
    _distinct_levels(wide.columns)
    try:
        y = wide.to_numpy(dtype=float)
    except (TypeError, ValueError):
        raise ValueError("cells must hold numbers only (a subject x level table)") from None
    if y.ndim != 2 or y.shape[0] < 2 or y.shape[1] < 2:
        raise ValueError(f"cells must be a subject x level table with >= 2 subjects and >= 2 levels, got shape {y.shape}")
    if not np.isfinite(y).all():
        raise ValueError("cells must be a complete table of finite numbers (no NaN: every subject needs every level)")
    return wide


def _constant_differences(d, z, e, values):
    """Why the paired t of differences ``d`` (in units ``2^e``) is undefined, or None when it is defined."""
    if not _negligible(float(np.sum((d - d.mean()) ** 2)), z.ravel()):
        return None
    what = "identical for every subject" if not d.any() else \
        f"the same for every subject ({_ldexp_quiet(d[0], e):g})" if np.all(d == d[0]) else \
        "the same for every subject to within 1e-13 of the largest value " \
        f"({np.max(np.abs(values)):.6g}): too little to tell from rounding"
    return f"the paired differences are {what}, so the paired t statistic is undefined (zero variance)"


def holm(p):
    """Holm's step-down adjusted p-values: sorted ascending, ``p_(i) (m - i + 1)`` made monotone and capped at 1
    (the same numbers as statsmodels' ``multipletests(method="holm")``, without its per-call garbage collection)."""
    p = np.asarray(p, dtype=float)
    if p.ndim != 1 or not ((p >= 0) & (p <= 1)).all():
        raise ValueError(f"p must be a 1-D array of probabilities in [0, 1], got {p!r}")
    order = np.argsort(p, kind="stable")
    adjusted = np.minimum(1.0, np.maximum.accumulate(p[order] * (len(p) - np.arange(len(p)))))
    out = np.empty_like(p)
    out[order] = adjusted
    return out


def pairwise_comparisons(anova, as_records=False, allow_large=None, undefined="raise"):
    """Every pair of levels of an :class:`RMAnova`: the RM-error Tukey HSD (``q``, ``p_tukey``) beside the
    paired t-test with Holm's correction (``t``, ``df``, ``p_t``, ``p_holm``), one row per pair with
    ``A``, ``B``, ``mean_A``, ``mean_B`` and ``diff = mean_A - mean_B``. ``as_records=True`` returns a list
    of dicts of plain Python numbers and strings (ready for JSON). Raises :class:`DegenerateDataError` as
    :func:`paired_t_holm` does (``undefined="leave"``: NaN t and p for such a pair, the reasons in
    ``attrs["undefined"]``; Tukey's q uses the pooled error term and stays defined), and
    :class:`mutual.budget.TooLarge` for more pairs than the limits allow (``allow_large`` as :func:`tukey_rm`)."""
    if not isinstance(anova, RMAnova):
        raise ValueError(f"anova must be an RMAnova, got {type(anova).__name__}")
    tukey = tukey_rm(anova, allow_large=allow_large).rename(columns={"p": "p_tukey"})
    paired = paired_t_holm(anova, allow_large=allow_large, undefined=undefined)
    table = tukey.merge(paired.rename(columns={"p": "p_t"}).drop(columns="mean_diff"), on=["A", "B"], how="left")
    table.attrs["undefined"] = paired.attrs["undefined"]
    if not as_records:
        return table
    plain = {"A": str, "B": str, "df": int}
    return [{k: plain.get(k, float)(v) for k, v in row.items()} for row in table.to_dict("records")]


def likert_vs_neutral(answers, neutral=4.0):
    """One-sample t-test of Likert answers against the neutral point (section 5.3.2).

    Answers must be whole numbers in 1..7, at least two, not all equal (then t is undefined:
    :class:`DegenerateDataError`). Returns dict(mean, t, df, p, n).
    """
    try:
        a = np.asarray(answers, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"answers must be numbers, got {answers!r}") from None
    lo, hi = LIKERT_RANGE
    if a.ndim != 1 or a.size < 2:
        raise ValueError(f"answers must be a 1-D sequence of at least 2 answers, got shape {a.shape}")
    if not np.isfinite(a).all() or ((a < lo) | (a > hi)).any() or not np.allclose(a, np.round(a)):
        raise ValueError(f"answers must be whole numbers in {lo}..{hi}")
    if isinstance(neutral, bool) or not isinstance(neutral, (int, float, np.number)) or not lo <= neutral <= hi:
        raise ValueError(f"neutral must be a number in {lo}..{hi}, got {neutral!r}")
    if np.all(a == a[0]):
        raise DegenerateDataError(f"all {a.size} answers are {a[0]:g}: with zero variance the t statistic is "
                                  f"undefined; report the answers themselves")
    res = stats.ttest_1samp(a, neutral)
    return {"mean": float(a.mean()), "t": float(res.statistic), "df": int(a.size - 1),
            "p": float(res.pvalue), "n": int(a.size)}


def significance_stars(p):
    """'***' (p < .001), '**' (< .01), '*' (< .05) or 'n.s.'."""
    if isinstance(p, bool) or not isinstance(p, (int, float, np.number)) or not 0 <= p <= 1:
        raise ValueError(f"p must be a probability in [0, 1], got {p!r}")
    return "***" if p < 0.001 else "**" if p < 0.01 else "*" if p < 0.05 else "n.s."
