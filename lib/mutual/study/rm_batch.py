"""The chapter 5 analysis (Sec. 5.3.1) vectorized over many simulated data sets, for Monte Carlo power.

:func:`rm_analyses` computes, for ``R`` subject x level tables at once, what
:func:`mutual.study.stats.rm_anova` (F, p, MSE, Greenhouse-Geisser epsilon and p),
:func:`mutual.study.stats.tukey_rm` (repeated-measures Tukey HSD) and
:func:`mutual.study.stats.paired_t_holm` (paired t-tests, Holm) compute for one; the tests check
that they agree to 1e-9. The study's own functions take about 0.17 s per table (statsmodels'
``AnovaRM`` on a long table), too slow for tens of thousands of simulated cohorts.

:func:`gaussian_rm_power` simulates Gaussian repeated-measures data with given means and
covariance: the independent check of the analytic power of :mod:`.power`, and the bridge between
the analytic curve and the cohort simulation (same means and covariance, Gaussian tails).
"""

import functools
from dataclasses import dataclass
from itertools import combinations

import numpy as np
from scipy import stats


_RELATIVE_ZERO = 1e-13  # as mutual.study.stats: sums of squares this small relative to the data are zero


@functools.lru_cache(maxsize=256)
def tukey_critical_value(alpha, m, df):
    """``q(alpha; m, df)`` of the studentized range (cached: scipy integrates it numerically)."""
    return float(stats.studentized_range.isf(alpha, m, df))


def level_pairs(m):
    """Index pairs ``(i, j)``, ``i < j``, in the order of :func:`mutual.study.stats.tukey_rm`."""
    return list(combinations(range(m), 2))


@dataclass(frozen=True)
class BatchRM:
    """Analyses of ``R`` tables of ``n`` subjects x ``m`` levels (arrays over the first axis; pair
    columns in :func:`level_pairs` order). ``diff`` = mean_i - mean_j, ``q`` the Tukey statistic,
    ``t`` / ``p_paired`` / ``p_holm`` the paired t-tests. Statistics the data leave undefined (where
    the study's functions raise :class:`mutual.study.errors.DegenerateDataError`: no within-subject
    variation, zero residual variance, constant paired differences) are NaN, and never reject."""
    n: int
    m: int
    F: np.ndarray
    p: np.ndarray
    mse: np.ndarray
    epsilon_gg: np.ndarray
    p_gg: np.ndarray
    diff: np.ndarray
    q: np.ndarray
    t: np.ndarray
    p_paired: np.ndarray
    p_holm: np.ndarray

    def __repr__(self):
        return f"BatchRM({len(self.F)} tables of {self.n} subjects x {self.m} levels)"

    @property
    def df(self):
        """Error degrees of freedom ``(m - 1)(n - 1)`` of F and of the Tukey test."""
        return (self.m - 1) * (self.n - 1)

    def tukey_reject(self, alpha=0.05):
        """Whether each pair's Tukey HSD rejects at ``alpha`` (``q`` above the critical value)."""
        return np.nan_to_num(self.q, nan=-np.inf) > tukey_critical_value(alpha, self.m, self.df)

    def tukey_p(self):
        """Tukey p-values (slow: about 5 ms each)."""
        return stats.studentized_range.sf(self.q, self.m, self.df)


def _holm(p):
    """Holm-adjusted p-values along the last axis (as statsmodels ``multipletests(method='holm')``)."""
    k = p.shape[-1]
    order = np.argsort(p, axis=-1, kind="stable")
    ranked = np.take_along_axis(p, order, axis=-1) * (k - np.arange(k))
    adjusted = np.minimum(1.0, np.maximum.accumulate(ranked, axis=-1))
    out = np.empty_like(adjusted)
    np.put_along_axis(out, order, adjusted, axis=-1)
    return out


def rm_analyses(y):
    """The Sec. 5.3.1 analyses of each subject x level table in ``y`` (shape ``(R, n, m)``): see
    :class:`BatchRM` and the module docstring."""
    y = np.asarray(y, dtype=float)
    if y.ndim == 2:
        y = y[None]
    if y.ndim != 3 or y.shape[1] < 2 or y.shape[2] < 2:
        raise ValueError(f"y must have shape (R, n >= 2, m >= 2), got {y.shape}")
    if not np.isfinite(y).all():
        raise ValueError("y must hold finite numbers (a complete, balanced design)")
    _, n, m = y.shape
    subj, lev, grand = y.mean(axis=2), y.mean(axis=1), y.mean(axis=(1, 2))
    resid = y - subj[:, :, None] - lev[:, None, :] + grand[:, None, None]
    df1, df2 = m - 1, (m - 1) * (n - 1)
    ss_err = np.sum(resid ** 2, axis=(1, 2))
    ss_lev = n * np.sum((lev - grand[:, None]) ** 2, axis=1)
    ss_within = np.sum((y - subj[:, :, None]) ** 2, axis=(1, 2))
    zero = y[0].size * (_RELATIVE_ZERO * np.abs(y).max(axis=(1, 2))) ** 2  # the study's "zero up to rounding"
    defined = (ss_within > zero) & (ss_err > zero)
    ms_lev = np.where(ss_lev > zero, ss_lev, 0.0) / df1
    mse = ss_err / df2
    with np.errstate(divide="ignore", invalid="ignore"):
        F = np.where(defined, ms_lev / mse, np.nan)
    eps = _gg_epsilon(y)
    p = stats.f.sf(F, df1, df2)
    p_gg = stats.f.sf(F, eps * df1, eps * df2)
    pairs = level_pairs(m)
    a, b = np.array([i for i, _ in pairs]), np.array([j for _, j in pairs])
    diff = lev[:, a] - lev[:, b]
    with np.errstate(divide="ignore", invalid="ignore"):
        q = np.where(defined[:, None], np.abs(diff) / np.sqrt(mse / n)[:, None], np.nan)
        d = y[:, :, a] - y[:, :, b]
        sd = d.std(axis=1, ddof=1)
        pair_max = np.maximum(np.abs(y[:, :, a]).max(axis=1), np.abs(y[:, :, b]).max(axis=1))
        varies = (n - 1) * sd ** 2 > 2 * n * (_RELATIVE_ZERO * pair_max) ** 2
        t = np.where(varies, d.mean(axis=1) / (sd / np.sqrt(n)), np.nan)
    p_paired = 2 * stats.t.sf(np.abs(t), n - 1)
    p_holm = _holm(np.nan_to_num(p_paired, nan=1.0))
    p_holm[np.isnan(p_paired)] = np.nan
    return BatchRM(n=n, m=m, F=F, p=p, mse=mse, epsilon_gg=eps, p_gg=p_gg, diff=diff, q=q, t=t,
                   p_paired=p_paired, p_holm=p_holm)


def _gg_epsilon(y):
    """Greenhouse-Geisser epsilon of each table (as :func:`mutual.study.stats.greenhouse_geisser_epsilon`)."""
    _, n, m = y.shape
    centred = y - y.mean(axis=1, keepdims=True)
    s = np.einsum("rni,rnj->rij", centred, centred) / (n - 1)
    c = np.eye(m) - 1.0 / m
    sdc = c @ s @ c
    denom = (m - 1) * np.sum(sdc ** 2, axis=(1, 2))
    tr = np.trace(sdc, axis1=1, axis2=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(denom > 0, np.clip(tr ** 2 / denom, 1.0 / (m - 1), 1.0), 1.0)


# ------------------------------------------------------------------------------- Gaussian data

def compound_symmetry(m, rho, sd=1.0):
    """Covariance of ``m`` measures with standard deviation ``sd`` and common correlation ``rho``."""
    if not (-1.0 / (m - 1) < rho < 1):
        raise ValueError(f"rho must lie in (-1/(m-1), 1) for a valid covariance, got {rho!r}")
    return sd ** 2 * ((1 - rho) * np.eye(m) + rho * np.ones((m, m)))


def means_with_effect(f, m, sd=1.0):
    """Evenly spaced level means whose population SD is ``f * sd`` (G*Power's ``f = sigma_m / sigma``)."""
    z = np.arange(m) - (m - 1) / 2
    return f * sd * z / np.sqrt(np.mean(z ** 2))


def simulate_gaussian_rm(means, cov, n, reps, seed=0):
    """``reps`` tables of ``n`` subjects drawn from ``N(means, cov)``: shape ``(reps, n, m)``."""
    means, cov = np.asarray(means, dtype=float), np.asarray(cov, dtype=float)
    m = len(means)
    if means.ndim != 1 or cov.shape != (m, m) or not np.allclose(cov, cov.T):
        raise ValueError(f"means must be 1-D and cov a symmetric ({m}, {m}) matrix, got {means.shape}, {cov.shape}")
    if isinstance(n, bool) or int(n) != n or n < 2 or isinstance(reps, bool) or int(reps) != reps or reps < 1:
        raise ValueError(f"n must be an integer >= 2 and reps >= 1, got n={n!r}, reps={reps!r}")
    w, v = np.linalg.eigh(cov)
    if w.min() < -1e-12 * max(1.0, w.max()):
        raise ValueError("cov must be positive semi-definite")
    root = v * np.sqrt(np.clip(w, 0, None))
    z = np.random.default_rng(seed).standard_normal((int(reps), int(n), m))
    return means + z @ root.T


def gaussian_rm_power(means, cov, n, reps=4000, alpha=0.05, seed=0, chunk=2000):
    """Monte Carlo power of the Sec. 5.3.1 tests on Gaussian data ``N(means, cov)`` with ``n`` subjects.

    Returns a dict of rejection counts out of ``reps``: ``anova`` (uncorrected F), ``anova_gg``
    (Greenhouse-Geisser), and per pair (:func:`level_pairs` order) ``tukey``, ``holm`` and
    ``paired`` (uncorrected); plus ``reps`` and ``pairs``.
    """
    counts = {"anova": 0, "anova_gg": 0}
    m = len(means)
    for key in ("tukey", "holm", "paired"):
        counts[key] = np.zeros(m * (m - 1) // 2, int)
    rng = np.random.default_rng(seed)
    done = 0
    while done < reps:
        k = min(chunk, reps - done)
        res = rm_analyses(simulate_gaussian_rm(means, cov, n, k, rng))
        counts["anova"] += int(np.sum(res.p < alpha))
        counts["anova_gg"] += int(np.sum(res.p_gg < alpha))
        counts["tukey"] += res.tukey_reject(alpha).sum(axis=0)
        counts["holm"] += np.sum(res.p_holm < alpha, axis=0)
        counts["paired"] += np.sum(res.p_paired < alpha, axis=0)
        done += k
    counts.update(reps=int(reps), pairs=level_pairs(m))
    return counts
