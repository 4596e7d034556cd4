"""Analytic power for replicating the chapter 5 study (the study: Sec. 5.2-5.3.1).

The omnibus test is the one-way repeated-measures ANOVA of Sec. 5.3.1 (``F(2, 20) = 8.72`` with
11 participants and 3 safe sets). Its power follows G*Power's "ANOVA: repeated measures, within
factors" (Faul et al. 2007): with ``N`` subjects, ``m`` levels, correlation ``rho`` among the
repeated measures and non-sphericity correction ``epsilon``,

    lambda = f^2 N m epsilon / (1 - rho),  df1 = (m - 1) epsilon,  df2 = (N - 1)(m - 1) epsilon,

and power = P(F'(df1, df2, lambda) > F_crit(alpha; df1, df2)) from scipy's noncentral F. Here
``f = sigma_means / sigma`` is G*Power's effect size on the scale of one measurement's standard
deviation. A *partial* eta squared (what an RM-ANOVA reports, SS_effect / (SS_effect + SS_error))
already carries the correlation in its error term: ``f_p^2 = eta_p^2 / (1 - eta_p^2)`` and
``lambda = f_p^2 N m epsilon``.

Effect sizes from a reported F (:func:`effect_size_from_f`) are biased upwards, badly so in small
studies; we give the plain partial eta squared, two corrections and a confidence interval.

The paired contrasts (Learned vs Standard) have closed forms where the test's critical value is
fixed: the paired t-test (uncorrected or Bonferroni) and the repeated-measures Tukey HSD of
:func:`mutual.study.stats.tukey_rm` under sphericity. Holm's step-down has none: the power of a
contrast then depends on the other contrasts, and :mod:`.rm_batch` simulates it.
"""

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import optimize, stats

from ..inputs import check_number, number, probability
from .published import design_from_f_dofs
from .rm_batch import tukey_critical_value


def _effect(f, partial_eta_squared, rho, m=None):
    """``f_p^2``, the squared effect on the error scale, from exactly one of the two effect sizes."""
    if (f is None) == (partial_eta_squared is None):
        raise ValueError("give exactly one of f (G*Power's effect size, with rho) and partial_eta_squared")
    if f is not None:
        if not (np.isfinite(number("f", f)) and f >= 0):
            raise ValueError(f"f must be a non-negative number, got {f!r}")
        low = -1.0 / (m - 1) if m is not None else -1.0
        if rho is None or not (np.isfinite(number("rho", rho)) and low <= rho < 1):
            where = f"[-1/(m-1), 1) = [{low:.4g}, 1) for m = {m} measurements" if m is not None else "(-1, 1)"
            raise ValueError(f"rho (correlation among the repeated measures) must lie in {where}, got {rho!r}: "
                             "below -1/(m-1) no covariance matrix has equal correlations")
        if float(f) > 1e150:
            raise ValueError(f"f must be at most 1e150 (f^2 must stay within the range of doubles), got {f!r}")
        return float(f) ** 2 / (1.0 - rho)
    if rho is not None:
        raise ValueError("rho must not be given with partial_eta_squared: its error term already holds the "
                         "correlation (f_p^2 = eta_p^2 / (1 - eta_p^2))")
    if not (np.isfinite(number("partial_eta_squared", partial_eta_squared)) and 0 <= partial_eta_squared < 1):
        raise ValueError(f"partial_eta_squared must lie in [0, 1), got {partial_eta_squared!r}")
    return partial_eta_squared / (1.0 - partial_eta_squared)


def _epsilon(epsilon, m):
    if not (np.isfinite(number("epsilon", epsilon)) and 1.0 / (m - 1) - 1e-12 <= epsilon <= 1):
        raise ValueError(f"epsilon must lie in [1/(m-1), 1] = [{1 / (m - 1):.3g}, 1], got {epsilon!r}")
    return float(epsilon)


def rm_anova_noncentrality(n, m, f=None, partial_eta_squared=None, rho=None, epsilon=1.0):
    """``(lambda, df1, df2)`` of G*Power's repeated-measures, within-factors F test (module docstring)."""
    n, m = check_number("n", n, low=2, integer=True), check_number("m", m, low=2, integer=True)
    fp2 = _effect(f, partial_eta_squared, rho, m)
    eps = _epsilon(epsilon, m)
    lam = fp2 * n * m * eps
    if not np.isfinite(lam):
        raise ValueError(f"the noncentrality f_p^2 N m epsilon = {fp2:.3g} x {n} x {m} x {eps:g} is beyond the range of "
                         "doubles (the power is 1 for any N)")
    return lam, (m - 1) * eps, (n - 1) * (m - 1) * eps


#: from this noncentrality on, scipy's noncentral F series stops converging (wrong by 0.25 at 1e11)
NC_ASYMPTOTIC = 1e10


def noncentral_f_sf(x, dfn, dfd, nc, lower=False):
    """``P(F' > x)`` (``lower=True``: ``P(F' <= x)``) of the noncentral ``F'(dfn, dfd, nc)``, guarded.

    ``nc = 0`` is the central F (scipy's ``ncf`` returns ``sf = -0.95`` there). From ``nc = 1e10``
    (:data:`NC_ASYMPTOTIC`) the large-noncentrality limit: the numerator concentrates at its mean,
    ``F' -> ((nc + dfn) / dfn) / (chi2_dfd / dfd)``, so ``P(F' > x) = P(chi2_dfd < dfd (nc + dfn) / (dfn x))``
    (within 1e-8 of scipy at 1e10, closer beyond). A value scipy gives outside [0, 1] raises ValueError.
    """
    x, dfn, dfd, nc = (number(k, v) for k, v in (("x", x), ("dfn", dfn), ("dfd", dfd), ("nc", nc)))
    if not (dfn > 0 and dfd > 0 and np.isfinite(dfn) and np.isfinite(dfd)) or not (nc >= 0) or np.isnan(x):
        raise ValueError(f"the noncentral F needs positive finite degrees of freedom, nc >= 0 and a number x; got "
                         f"dfn={dfn!r}, dfd={dfd!r}, nc={nc!r}, x={x!r}")
    if x <= 0 or x == np.inf:
        upper = 1.0 if x <= 0 else 0.0
    elif nc == 0:
        upper = stats.f.cdf(x, dfn, dfd) if lower else stats.f.sf(x, dfn, dfd)
        return float(upper)
    elif nc >= NC_ASYMPTOTIC:
        threshold = dfd * ((nc + dfn) / dfn) / x
        return float(stats.chi2.sf(threshold, dfd) if lower else stats.chi2.cdf(threshold, dfd))
    else:
        value = float(stats.ncf.cdf(x, dfn, dfd, nc) if lower else stats.ncf.sf(x, dfn, dfd, nc))
        if not (np.isfinite(value) and -1e-12 <= value <= 1 + 1e-12):
            raise ValueError(f"the noncentral F(dfn={dfn:g}, dfd={dfd:g}, nc={nc:g}) at x={x:g} is not computable "
                             f"(scipy gave {value!r})")
        return float(np.clip(value, 0.0, 1.0))
    return 1.0 - upper if lower else upper


def rm_anova_power(n, m, f=None, partial_eta_squared=None, rho=None, epsilon=1.0, alpha=0.05):
    """Power of the one-way repeated-measures ANOVA (G*Power, "repeated measures, within factors").

    ``n`` subjects, ``m`` levels, effect ``f`` with correlation ``rho`` (or ``partial_eta_squared``),
    sphericity correction ``epsilon`` in ``[1/(m-1), 1]``, level ``alpha``.
    """
    alpha = probability("alpha", alpha)
    lam, df1, df2 = rm_anova_noncentrality(n, m, f, partial_eta_squared, rho, epsilon)
    crit = stats.f.isf(alpha, df1, df2)
    return noncentral_f_sf(crit, df1, df2, lam)      # alpha at zero effect


def rm_anova_sample_size(power, m, f=None, partial_eta_squared=None, rho=None, epsilon=1.0, alpha=0.05,
                         n_max=100_000):
    """The smallest number of subjects whose :func:`rm_anova_power` reaches ``power`` (G*Power's
    "a priori" analysis; it reports the same integer)."""
    power = probability("power", power)
    if not power > probability("alpha", alpha):
        raise ValueError(f"power must exceed alpha, got power={power}, alpha={alpha}")
    kw = dict(f=f, partial_eta_squared=partial_eta_squared, rho=rho, epsilon=epsilon, alpha=alpha)
    if _effect(f, partial_eta_squared, rho, check_number("m", m, low=2, integer=True)) == 0:
        raise ValueError("the effect size is zero: no sample size reaches a power above alpha")
    if rm_anova_power(n_max, m, **kw) < power:
        raise ValueError(f"even n_max={n_max} subjects do not reach power {power}")
    lo, hi = 2, 2
    while rm_anova_power(hi, m, **kw) < power:
        lo, hi = hi, hi * 2
    while lo < hi:  # power grows with n: bisect for the first n reaching the target
        mid = (lo + hi) // 2
        if rm_anova_power(mid, m, **kw) >= power:
            hi = mid
        else:
            lo = mid + 1
    return int(lo)


@dataclass(frozen=True)
class EffectSizeEstimate:
    """Effect size of a one-way repeated-measures design read from a reported ``F(df1, df2)``.

    * ``eta2p``: partial eta squared, ``F df1 / (F df1 + df2)``: biased upwards.
    * ``epsilon2p``: partial epsilon squared, ``df1 (F - 1) / (F df1 + df2)`` (Kelley's correction).
    * ``omega2p``: the omega-squared-style estimate from the moment estimate of the noncentrality,
      ``lambda = df1 (F - 1)``: ``f_p^2 = lambda / (N m)``, ``omega2p = f_p^2 / (1 + f_p^2)``.
    * ``lambda_unbiased``: ``df1 F (df2 - 2) / df2 - df1``, the unbiased estimate of the
      noncentrality (``E F' = df2 (df1 + lambda) / (df1 (df2 - 2))``), truncated at 0; ``eta2p_unbiased``
      the partial eta squared it implies. This is our bias-corrected estimate for planning.
    * ``lambda_ci`` and ``eta2p_ci``: the ``confidence`` interval of the noncentrality by inverting
      the noncentral F (Steiger 2004), and the partial eta squared at its ends.
    """
    F: float
    df1: int
    df2: int
    m: int
    n: int
    eta2p: float
    epsilon2p: float
    omega2p: float
    lambda_unbiased: float
    eta2p_unbiased: float
    lambda_ci: tuple
    eta2p_ci: tuple
    confidence: float

    def __repr__(self):
        lo, hi = self.eta2p_ci
        return (f"EffectSizeEstimate(F({self.df1}, {self.df2}) = {self.F:.3g}: eta2p = {self.eta2p:.3f}, "
                f"bias-corrected {self.eta2p_unbiased:.3f}, {self.confidence:.0%} CI [{lo:.3f}, {hi:.3f}])")

    @property
    def f_partial(self):
        """``f_p = sqrt(eta2p / (1 - eta2p))`` of the plain (biased) estimate."""
        return float(np.sqrt(self.eta2p / (1 - self.eta2p)))

    @property
    def f_partial_unbiased(self):
        """``f_p`` of the bias-corrected estimate, ``sqrt(lambda_unbiased / (N m))``."""
        return float(np.sqrt(self.lambda_unbiased / (self.n * self.m)))


def noncentrality_interval(F, df1, df2, confidence=0.95):
    """Confidence interval of the noncentrality of an observed ``F(df1, df2)`` (Steiger 2004):
    ``lambda_lo`` with ``P(F' <= F | lambda_lo) = 1 - a/2`` and ``lambda_hi`` with ``a/2``
    (``a = 1 - confidence``); an end is 0 where even ``lambda = 0`` makes ``F`` that unlikely."""
    confidence = probability("confidence", confidence)
    if not (np.isfinite(number("F", F)) and F >= 0):
        raise ValueError(f"F must be a non-negative number (finite), got {F!r}")
    a = 1.0 - confidence

    def end(target):
        g = lambda lam: noncentral_f_sf(F, df1, df2, lam, lower=True) - target  # decreases in lambda
        if g(0.0) <= 0:
            return 0.0
        hi = max(10.0, 4 * F * df1)
        while g(hi) > 0:
            hi *= 2
        return float(optimize.brentq(g, 0.0, hi, xtol=1e-10, rtol=1e-12))

    return end(1 - a / 2), end(a / 2)


def unbiased_noncentrality(F, df1, df2):
    """``df1 F (df2 - 2) / df2 - df1``: unbiased for the noncentrality of ``F'(df1, df2, lambda)``, whose
    mean is ``df2 (df1 + lambda) / (df1 (df2 - 2))`` (``df2 > 2``); not truncated (may be negative)."""
    if not df2 > 2:
        raise ValueError(f"df2 must exceed 2, got {df2!r}")
    return df1 * np.asarray(F, dtype=float) * (df2 - 2) / df2 - df1


def effect_size_from_f(F, df1, df2, confidence=0.95):
    """What a reported one-way repeated-measures ``F(df1, df2)`` says about the effect (see
    :class:`EffectSizeEstimate`). E.g. the thesis's ``F(2, 20) = 8.72`` (Sec. 5.3.1)."""
    if not (np.isfinite(number("F", F)) and F >= 0):
        raise ValueError(f"F must be a non-negative number (finite), got {F!r}")
    shape = design_from_f_dofs(df1, df2)  # raises for an F that is not one-way repeated measures
    m, n = shape["levels"], shape["subjects"]
    if df2 <= 2:
        raise ValueError(f"df2 must exceed 2 for the unbiased noncentrality, got {df2!r}")
    to_eta = lambda lam: lam / (lam + n * m)
    lam_u = max(0.0, float(unbiased_noncentrality(F, df1, df2)))
    lam_m = max(0.0, df1 * (F - 1))
    ci = noncentrality_interval(F, df1, df2, confidence)
    return EffectSizeEstimate(F=float(F), df1=int(df1), df2=int(df2), m=m, n=n, eta2p=F * df1 / (F * df1 + df2),
                              epsilon2p=max(0.0, df1 * (F - 1) / (F * df1 + df2)), omega2p=to_eta(lam_m),
                              lambda_unbiased=lam_u, eta2p_unbiased=to_eta(lam_u), lambda_ci=ci,
                              eta2p_ci=(to_eta(ci[0]), to_eta(ci[1])), confidence=float(confidence))


# ------------------------------------------------------------------------------- paired contrasts

def _two_sided_t_power(ncp, df, crit):
    if ncp == 0:
        return float(2 * stats.t.sf(crit, df))
    power = stats.nct.sf(crit, df, ncp) + stats.nct.cdf(-crit, df, ncp)
    if not (np.isfinite(power) and 0 <= power <= 1 + 1e-12):  # scipy's noncentral t fails far in the tail
        power = stats.norm.sf(crit - ncp) + stats.norm.cdf(-crit - ncp)   # (large df and ncp): the normal limit
    return float(min(power, 1.0))


def _dz(dz):
    if not np.isfinite(dz):
        raise ValueError(f"dz must be a finite number, got {dz!r}")
    return abs(float(dz))


def paired_t_power(dz, n, alpha=0.05, comparisons=1):
    """Power of a two-sided paired t-test with standardized mean difference ``dz`` (mean of the
    differences over their SD) and ``n`` subjects, at ``alpha / comparisons`` (Bonferroni; with
    ``comparisons=1`` uncorrected). Holm's step-down rejects at least what Bonferroni rejects, so
    this is a lower bound of a contrast's power under Holm, and ``comparisons=1`` an upper one."""
    n = check_number("n", n, low=2, integer=True)
    comparisons = check_number("comparisons", comparisons, low=1, integer=True)
    level = probability("alpha", alpha) / comparisons
    return _two_sided_t_power(_dz(dz) * np.sqrt(n), n - 1, stats.t.isf(level / 2, n - 1))


def tukey_rm_power(dz, n, m, alpha=0.05):
    """Power of one pair of the repeated-measures Tukey HSD (:func:`mutual.study.stats.tukey_rm`):
    ``q = |mean_i - mean_j| / sqrt(MSE / n)`` against the studentized range ``q(alpha; m, df)``,
    ``df = (m - 1)(n - 1)``. Under sphericity the difference has variance ``2 MSE_pop / n`` and is
    independent of MSE, so ``q / sqrt 2`` is a noncentral |t| with ``df`` and ``ncp = dz sqrt(n)``:
    exact, where ``dz`` is the pair's standardized paired difference."""
    n, m = check_number("n", n, low=2, integer=True), check_number("m", m, low=2, integer=True)
    alpha = probability("alpha", alpha)
    df = (m - 1) * (n - 1)
    return _two_sided_t_power(_dz(dz) * np.sqrt(n), df, tukey_critical_value(alpha, m, df) / np.sqrt(2))


def contrast_sample_size(dz, power, m=3, alpha=0.05, test="tukey", n_max=10_000):
    """Smallest ``n`` whose contrast power (``test``: ``"tukey"``, ``"paired"`` uncorrected or
    ``"bonferroni"`` over the ``m (m - 1) / 2`` pairs) reaches ``power``."""
    power = probability("power", power)
    pairs = m * (m - 1) // 2
    fns = {"tukey": lambda n: tukey_rm_power(dz, n, m, alpha), "paired": lambda n: paired_t_power(dz, n, alpha),
           "bonferroni": lambda n: paired_t_power(dz, n, alpha, pairs)}
    if test not in fns:
        raise ValueError(f"test must be one of {sorted(fns)}, got {test!r}")
    if _dz(dz) == 0 or fns[test](n_max) < power:
        raise ValueError(f"dz={dz!r} does not reach power {power} with up to n_max={n_max} subjects")
    lo, hi = 2, 2
    while fns[test](hi) < power:
        lo, hi = hi, min(2 * hi, n_max)
    while lo < hi:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if fns[test](mid) >= power else (mid + 1, hi)
    return int(lo)


def dz_from_summary(mean_a, mean_b, mse):
    """Standardized paired difference of two levels under sphericity from their means and the
    repeated-measures error term (``Var(y_a - y_b) = 2 MSE``), e.g. from Table 5.1 and the MSE
    :func:`mutual.study.stats.recover_from_summary` recovers."""
    if not (np.isfinite(mse) and mse > 0):
        raise ValueError(f"mse must be a positive number, got {mse!r}")
    return float((mean_a - mean_b) / np.sqrt(2 * mse))


# ------------------------------------------------------------------------------- Monte Carlo helpers

def wilson_interval(successes, trials, confidence=0.95):
    """Wilson score interval of a binomial proportion (Monte Carlo power estimates)."""
    successes, trials = np.asarray(successes, dtype=float), np.asarray(trials, dtype=float)
    if not (np.isfinite(successes).all() and np.isfinite(trials).all()):
        raise ValueError(f"successes and trials must be finite counts, got {successes!r} and {trials!r}")
    if np.any(trials < 1) or np.any(successes < 0) or np.any(successes > trials):
        raise ValueError("need 0 <= successes <= trials and trials >= 1")
    z = stats.norm.isf((1 - probability("confidence", confidence)) / 2)
    p = successes / trials
    centre = (p + z * z / (2 * trials)) / (1 + z * z / trials)
    half = z * np.sqrt(p * (1 - p) / trials + z * z / (4 * trials ** 2)) / (1 + z * z / trials)
    return np.clip(centre - half, 0, 1), np.clip(centre + half, 0, 1)


def recommended_n(n_values, power, target):
    """The smallest ``n`` from which the estimated ``power`` stays at or above ``target`` (so a
    Monte Carlo wiggle above the target before the curve settles does not count); None if never."""
    n_values, power = np.asarray(n_values), np.asarray(power, dtype=float)
    if n_values.shape != power.shape or n_values.ndim != 1 or len(n_values) == 0:
        raise ValueError("n_values and power must be 1-D and equally long")
    if not (np.isfinite(power).all() and ((power >= 0) & (power <= 1)).all()):
        raise ValueError(f"power must hold probabilities in [0, 1], got {power!r}")
    order = np.argsort(n_values)
    n_values, power = n_values[order], power[order]
    below = np.flatnonzero(power < target)
    if len(below) == 0:
        return int(n_values[0])
    return int(n_values[below[-1] + 1]) if below[-1] + 1 < len(n_values) else None


def replication_plan(F, df1, df2, targets=(0.8, 0.9), alpha=0.05, safeguard=0.6, epsilon=1.0, n_max=100_000):
    """Analytic sample sizes for replicating a one-way repeated-measures study that reported
    ``F(df1, df2)`` (e.g. the thesis's ``F(2, 20) = 8.72``), one row per effect estimate of
    :func:`effect_size_from_f`: the plain partial eta squared, partial epsilon squared, the
    omega-squared-style and the unbiased-noncentrality (bias-corrected) estimates, the lower end of
    a ``safeguard`` confidence interval (safeguard power analysis, Perugini et al. 2014) and of the
    95% interval. Columns: ``estimate``, ``eta2p``, ``f_p``, the power at the original N, and the
    N reaching each target with sphericity correction ``epsilon`` (a nullable integer: missing where
    the estimate is 0 or no N up to ``n_max`` reaches the target, "not reached")."""
    est = effect_size_from_f(F, df1, df2)
    if est.eta2p >= 1 - 1e-12:
        raise ValueError(f"F({df1}, {df2}) = {F:g}: partial eta squared rounds to 1 (no error variance is left), so "
                         "every N >= 2 has power 1; there is nothing to plan")
    guard = effect_size_from_f(F, df1, df2, confidence=safeguard)
    estimates = {"plain partial eta squared": est.eta2p, "partial epsilon squared": est.epsilon2p,
                 "partial omega squared (moments)": est.omega2p, "bias-corrected (unbiased lambda)": est.eta2p_unbiased,
                 f"safeguard: lower end of the {safeguard:.0%} CI": guard.eta2p_ci[0],
                 f"lower end of the {est.confidence:.0%} CI": est.eta2p_ci[0]}
    rows = []
    for name, eta in estimates.items():
        kw = dict(partial_eta_squared=eta, epsilon=epsilon, alpha=alpha)
        row = {"estimate": name, "eta2p": eta, "f_p": float(np.sqrt(eta / (1 - eta))),
               f"power at N = {est.n}": rm_anova_power(est.n, est.m, **kw)}
        for t in targets:
            reached = eta > 0 and rm_anova_power(n_max, est.m, **kw) >= t
            row[f"N for {t:.0%}"] = rm_anova_sample_size(t, est.m, n_max=n_max, **kw) if reached else None
        rows.append(row)
    table = pd.DataFrame(rows)
    for t in targets:
        table[f"N for {t:.0%}"] = table[f"N for {t:.0%}"].astype("Int64")
    return table


def gpower_table(m, f, rho=0.5, epsilon=1.0, alpha=0.05, n_values=(), targets=(0.8,), n_max=100_000):
    """G*Power's "ANOVA: repeated measures, within factors" (one group) as a table: for each ``n`` in
    ``n_values`` its noncentrality ``lambda``, ``df1``, ``df2``, critical F and power (``kind`` "power at N"),
    and for each target power the smallest N reaching it (``kind`` "N for target"; ``n`` missing and power
    NaN where no N up to ``n_max`` reaches it, "not reached")."""
    rows = []
    for n in n_values:
        lam, df1, df2 = rm_anova_noncentrality(n, m, f=f, rho=rho, epsilon=epsilon)
        rows.append({"kind": "power at N", "target": None, "n": int(n), "lambda": lam, "df1": df1, "df2": df2,
                     "F_crit": float(stats.f.isf(probability("alpha", alpha), df1, df2)),
                     "power": rm_anova_power(n, m, f=f, rho=rho, epsilon=epsilon, alpha=alpha)})
    for t in targets:
        t = probability("power", t)
        kw = dict(f=f, rho=rho, epsilon=epsilon, alpha=alpha)
        reached = _effect(f, None, rho, m) > 0 and t > alpha and rm_anova_power(n_max, m, **kw) >= t
        n = rm_anova_sample_size(t, m, n_max=n_max, **kw) if reached else None
        lam, df1, df2 = rm_anova_noncentrality(n or 2, m, f=f, rho=rho, epsilon=epsilon)
        rows.append({"kind": "N for target", "target": t, "n": n, "lambda": lam if n else None, "df1": df1,
                     "df2": df2 if n else None, "F_crit": float(stats.f.isf(alpha, df1, df2)) if n else None,
                     "power": rm_anova_power(n, m, **kw) if n else None})
    table = pd.DataFrame(rows, columns=["kind", "target", "n", "lambda", "df1", "df2", "F_crit", "power"])
    table["n"] = table["n"].astype("Int64")
    return table
