"""The maximum-likelihood safe set of a supervisor from their interventions (Sec. 4.4,
eqs. 4.8-4.12): the library member, margin ``mu`` and noise ``sigma`` that make the observed
intervention states most likely; and how often it recovers simulated supervisors."""

import functools
import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..seeds import generator
from .control import wilson_interval
from ..inputs import positive, real
from .dubins import TRUE_W_MAX, check_states, closed_form_values
from .exact import exact_counterpart, has_closed_form, interpolated_closed_form
from .supervisor import NoisySupervisor, collect_interventions
from .value_function import ValueFunction, ValueLibrary, unsafe_set_contains

PRIORS = ("mle", "map")
VALUES = ("auto", "exact", "grid")


class GridValueWarning(UserWarning):
    """A fit on grid-interpolated values sits within the grid's error: the bias the interpolation puts on
    the values at the interventions exceeds the standard error of the fitted margin mu."""


class LibraryEdgeWarning(UserWarning):
    """A supervisor fit sits on an edge of the library (or of the MAP prior's support): the best
    model may lie beyond the members that were searched."""


def _fmt(x):
    return f"{x:.4g}"


@dataclass(frozen=True, eq=False, repr=False)
class SupervisorFit:
    """The fitted supervisor: the chosen member (eq. 4.12) with its ``mu*``, ``sigma*`` (eq. 4.8).

    Per-member arrays: ``mus``, ``sigmas`` and ``logliks`` (log of eq. 4.9; ``-inf`` where the
    prior excludes the member), ``admissible`` (the prior's support). ``boundary`` is ``None`` when
    the chosen member has searched neighbours on both sides, ``"lowest"`` / ``"highest"`` when it is
    the slowest / most agile member searched (the library's, or the MAP prior's, edge), ``"only"``
    when a single member was searched; a :class:`LibraryEdgeWarning` says so when the fit is made.
    """
    library: ValueLibrary
    index: int
    mus: np.ndarray
    sigmas: np.ndarray
    logliks: np.ndarray
    admissible: np.ndarray
    n: int
    prior: str
    boundary: str = None
    values: str = "grid"
    value_error: float = float("nan")

    def __repr__(self):
        w = self.library.w_maxes
        levels = ", ".join(f"{name}={_fmt(self.level(k))}" for name, k in (("mu", 0), ("mu+sigma", 1),
                                                                           ("mu+2sigma", 2)))
        return (f"SupervisorFit(w_max={_fmt(self.w_max)}, mu={_fmt(self.mu)}, sigma={_fmt(self.sigma)}, "
                f"n={self.n}, prior={self.prior!r}, alpha levels: {levels}; library of {len(w)} members "
                f"w_max {_fmt(w.min())}..{_fmt(w.max())} ({self.library.method}), values={self.values!r}, "
                f"boundary={self.boundary!r})")

    @property
    def w_max(self):
        return float(self.library.w_maxes[self.index])

    @property
    def mu(self):
        return float(self.mus[self.index])

    @property
    def sigma(self):
        return float(self.sigmas[self.index])

    @property
    def loglik(self):
        return float(self.logliks[self.index])

    @property
    def value_fn(self):
        return self.library[self.index]

    def level(self, k=2.0):
        """The control level ``alpha = mu + k sigma`` of Sec. 4.5."""
        k_value = real(k)
        if k_value is None or not np.isfinite(k_value):
            raise ValueError(f"k must be a finite number, got {k!r}")
        return self.mu + k_value * self.sigma

    def coverage(self, states, k=2.0):
        """Fraction of intervention ``states`` at or below ``alpha = mu + k sigma`` of the fitted member:
        the interventions a robot avoiding at ``alpha`` keeps clear of (Sec. 4.5; ~Phi(k) in expectation)."""
        s = check_states(states)
        values = member_values(self.library, s, self.values)[self.index]
        if np.isnan(values).any():
            raise ValueError(f"states: {int(np.isnan(values).sum())} lie outside the library's grid "
                             f"(|x|, |y| <= {self.library.grid_spec.half_width})")
        return float(np.mean(values <= self.level(k)))


def expected_coverage(k, p):
    """The expected fraction of ``p`` Gaussian observations at or below their own MLE ``mu* + k sigma*``
    (eq. 4.8): the share of the learning interventions a robot avoiding at ``alpha = mu + k sigma`` keeps
    clear of (Sec. 4.5), exactly: with t = (v_i - mean) / sigma*, t^2 / (p - 1) ~ Beta(1/2, (p - 2) / 2), so
    the share is 1/2 + 1/2 I_{k^2 / (p - 1)}(1/2, (p - 2) / 2) for k >= 0; Phi(k) as p grows."""
    from scipy import stats

    k_value, p_value = real(k), real(p)
    if k_value is None or not np.isfinite(k_value) or k_value < 0:
        raise ValueError(f"k must be a finite number >= 0, got {k!r}")
    if p_value is None or p_value != int(p_value) or p_value < 3:
        raise ValueError(f"p must be an integer >= 3 (observations), got {p!r}")
    return float(0.5 + 0.5 * stats.beta.cdf(min(k_value ** 2 / (p_value - 1), 1.0), 0.5, (p_value - 2) / 2))


def gaussian_mle(values):
    """Eq. (4.8)-(4.9) per row of ``values`` (b, p): ``mu*``, ``sigma*`` and ``log L*``."""
    v = np.asarray(values, dtype=float)
    mu = v.mean(axis=-1)
    var = v.var(axis=-1)
    return mu, np.sqrt(var), _max_loglik(var, v.shape[-1])


def _max_loglik(var, p):
    """``log L*`` of eq. (4.9): with ``sigma^2`` the mean squared deviation, the exponent is ``-p/2``."""
    return -0.5 * p * (np.log(2 * np.pi * var) + 1)


def numerical_gaussian_fit(values, mu_min=None):
    """A second algorithm for eqs. (4.8)-(4.9): maximise the Gaussian log-likelihood of each row of
    ``values`` (b, p) numerically (scipy L-BFGS-B over ``mu`` and ``log sigma``) instead of by formula.

    ``mu_min=None``: the MLE. ``mu_min=0``: the MAP estimate of Sec. 4.4 under the prior that is zero
    for non-positive ``mu`` and uniform elsewhere (a bound ``mu >= 0``). Returns ``mu``, ``sigma`` and
    the maximised log-likelihood per row.
    """
    from scipy import optimize

    v = np.asarray(values, dtype=float)
    if v.ndim != 2 or v.shape[1] < 2 or not np.all(np.isfinite(v)):
        raise ValueError(f"values must be a finite (b, p >= 2) array, got shape {v.shape}")
    out = []
    for row in v:
        scale = max(float(np.std(row)), 1e-12)

        def negative_loglik(theta, row=row):
            mu, log_sigma = theta
            z = (row - mu) / np.exp(log_sigma)
            nll = 0.5 * np.sum(z ** 2) + len(row) * (log_sigma + 0.5 * np.log(2 * np.pi))
            grad = np.array([-np.sum(z) / np.exp(log_sigma), len(row) - np.sum(z ** 2)])
            return nll, grad

        # start away from the closed form (the median and twice the spread) so agreement is not by construction
        start = np.array([float(np.median(row)) if mu_min is None else max(float(np.median(row)), mu_min + scale),
                          np.log(2 * scale)])
        bounds = [(mu_min, None), (None, None)]
        res = optimize.minimize(negative_loglik, start, jac=True, method="L-BFGS-B", bounds=bounds,
                                options={"ftol": 1e-15, "gtol": 1e-12, "maxiter": 10000})
        out.append((res.x[0], np.exp(res.x[1]), -res.fun))
    mus, sigmas, logliks = map(np.array, zip(*out))
    return mus, sigmas, logliks


def _evaluation(library, values):
    """How the fit evaluates the library: "exact" (the closed form at the states) or "grid"."""
    if not isinstance(values, str) or values not in VALUES:
        raise ValueError(f"values must be one of {VALUES}, got {values!r}")
    closed = all(has_closed_form(m) for m in library)
    if values == "exact" and not closed:
        raise ValueError("values='exact': the library's members have a disturbance, for which no closed form exists; "
                         "use values='grid'")
    return "exact" if (values == "auto" and closed) or values == "exact" else "grid"


def member_values(library, states, values="auto"):
    """Every member's value at ``states`` (n, 3) -> (b, n): the closed form evaluated exactly where it exists
    (``values="auto"`` or ``"exact"``: no interpolation error) or trilinear interpolation on the grid
    (``"grid"``); NaN off the grid's (x, y) domain either way."""
    s = check_states(states)
    if _evaluation(library, values) == "grid" or library.members[0].exact:
        return library.interp_all(s)
    inside = np.all(np.abs(s[:, :2]) <= library.grid_spec.half_width, axis=1)
    out = np.stack([closed_form_values(s[:, 0], s[:, 1], s[:, 2], m.speed / m.w_max, m.obstacle_radius)
                    for m in library])
    return np.where(inside, out, np.nan)


def _grid_bias(library, states, index):
    """The mean error of the grid's values of member ``index`` at ``states``: against the closed form where it
    exists, else the closed form's own interpolation error on the same grid (no disturbance), a lower bound."""
    member = library[index]
    exact = closed_form_values(states[:, 0], states[:, 1], states[:, 2], member.speed / member.w_max,
                               member.obstacle_radius)
    if has_closed_form(member):
        return float(np.mean(member.interp(states) - exact))
    return float(np.mean(interpolated_closed_form(member.grid_spec, states, member.speed / member.w_max,
                                                  member.obstacle_radius) - exact))


@functools.lru_cache(maxsize=32)
def _conservative_members(library, reference):
    return np.array([unsafe_set_contains(member, reference) for member in library])


def _edge(index, admissible):
    """Where ``index`` sits among the searched (admissible) members: None, lowest, highest or only."""
    searched = np.flatnonzero(admissible)
    if len(searched) == 1:
        return "only"
    if index == searched[0]:
        return "lowest"
    if index == searched[-1]:
        return "highest"
    return None


def fit_supervisor(library, states, prior="mle", reference=None, values="auto"):
    """Fit the supervisor's safe set to intervention ``states`` (n, 3): eq. (4.8), (4.9), (4.12).

    ``prior="mle"``: the argmax of the maximised likelihood over the library. ``prior="map"``: the MAP
    estimate of Sec. 4.4 -- only members whose unsafe sets contain the ``reference`` (true dynamics;
    default the library member with ``w_max = 1``) unsafe set, and ``mu* = max(mu*, 0)`` with
    ``sigma*^2`` the mean squared deviation about it. Raises ValueError for fewer than two
    interventions, NaN, states outside the grid, or zero variance (an unbounded likelihood).
    A fit on the slowest or most agile member searched warns (:class:`LibraryEdgeWarning`) and
    says so in ``fit.boundary``: the supervisor may lie beyond the library's range.

    ``values``: how the members are evaluated at the interventions (:func:`member_values`): ``"auto"`` (the
    default) the exact closed form wherever it exists (a Dubins car without disturbance), else the grid;
    ``"grid"`` always the grid. On the grid the fit records the grid's bias at the interventions for the
    chosen member (``fit.value_error``: against the closed form, or for a library with a disturbance the
    closed form's interpolation error on the same grid) and warns (:class:`GridValueWarning`) when it
    exceeds the standard error of ``mu*``, sigma* / sqrt(n): the fitted margin then sits in the grid's error.
    """
    if not isinstance(library, ValueLibrary):
        raise ValueError("library must be a mutual.supervision.ValueLibrary")
    if not isinstance(prior, str) or prior not in PRIORS:
        raise ValueError(f"prior must be 'mle' or 'map', got {prior!r}")
    s = check_states(states)
    if len(s) < 2:
        raise ValueError(f"states must hold at least two interventions to estimate mu and sigma, got {len(s)}")
    evaluation = _evaluation(library, values)
    values = member_values(library, s, evaluation)
    outside = np.isnan(values[0])
    if outside.any():
        raise ValueError(f"states: {outside.sum()} interventions lie outside the library's grid "
                         f"(|x|, |y| <= {library.grid_spec.half_width} around the obstacle centre), e.g. the state "
                         f"{s[outside][0].tolist()} relative to it")
    mus = values.mean(axis=1)
    if prior == "map":
        if reference is None:
            if not np.any(np.abs(library.w_maxes - TRUE_W_MAX) <= 1e-9):
                raise ValueError(f"prior='map' needs reference= (the true dynamics' ValueFunction): the library "
                                 f"has no member with w_max = {TRUE_W_MAX:g} to use by default")
            reference = library[library.index_of(TRUE_W_MAX)]
        if not isinstance(reference, ValueFunction) or reference.grid_spec != library.grid_spec:
            raise ValueError("reference must be a ValueFunction on the library's grid")
        admissible = _conservative_members(library, reference)
        if not admissible.any():
            raise ValueError("no library member's unsafe set contains the reference unsafe set (MAP prior empty)")
        mus = np.maximum(mus, 0.0)
    else:
        if reference is not None:
            raise ValueError("reference is used only with prior='map'")
        admissible = np.ones(len(library), dtype=bool)
    var = np.mean((values - mus[:, None]) ** 2, axis=1)
    if np.any(var[admissible] <= 0):
        bad = library.w_maxes[admissible & (var <= 0)]
        raise ValueError(f"states: the interventions have zero variance under w_max={bad.tolist()}: the "
                         "likelihood is unbounded; states must be distinct")
    with np.errstate(divide="ignore"):
        logliks = np.where(admissible, _max_loglik(var, len(s)), -np.inf)
    index = int(np.argmax(logliks))
    boundary = _edge(index, admissible)
    if boundary is not None:
        searched = "the MAP prior's support" if prior == "map" and not admissible.all() else "the library"
        what = {"lowest": "the slowest-turning member of", "highest": "the most agile member of",
                "only": "the only member of"}[boundary]
        warnings.warn(f"the supervisor fit sits on {what} {searched} (w_max = {library.w_maxes[index]:g}; searched "
                      f"{library.w_maxes[admissible].min():g}..{library.w_maxes[admissible].max():g}): the best model "
                      "may lie beyond the members searched; extend the library to check", LibraryEdgeWarning,
                      stacklevel=2)
    error = float("nan")
    if evaluation == "grid" and not library.members[0].exact:
        error = _grid_bias(library, s, index)
        if abs(error) > np.sqrt(var[index] / len(s)):
            warnings.warn(f"the fit sits in the grid's error: at the {len(s)} interventions the grid's values of the "
                          f"chosen member (w_max = {library.w_maxes[index]:g}) are off by {error:+.3g} on average, more "
                          f"than the standard error of mu* ({np.sqrt(var[index] / len(s)):.3g}); evaluate exactly "
                          "(values='auto') or use a finer grid", GridValueWarning, stacklevel=2)
    return SupervisorFit(library, index, mus, np.sqrt(var), logliks, admissible, len(s), prior, boundary,
                         evaluation, error)


def recovery_study(library, generators, n_values, seeds, start_distance, prior="mle"):
    """How often the estimator recovers simulated noisy supervisors (Sec. 4.3-4.4).

    ``generators``: ``(w_max, mu, sigma)`` triples (``w_max`` a library member). For each generator
    and seed, a supervisor watches Phase II ``approach_scenes`` until it has intervened
    ``max(n_values)`` times (:func:`~mutual.supervision.supervisor.collect_interventions`); the fit
    uses its first ``n`` interventions. One row per (generator, seed, n): the estimates, whether
    ``w_max`` was recovered exactly, and ``boundary`` (the fit's library edge, or "").
    """
    if not isinstance(library, ValueLibrary):
        raise ValueError("library must be a mutual.supervision.ValueLibrary")
    try:
        n_values = sorted(int(n) for n in n_values if float(n) == int(n))
    except (TypeError, ValueError):
        raise ValueError(f"n_values must be integers >= 2, got {n_values!r}") from None
    if not n_values or n_values[0] < 2:
        raise ValueError(f"n_values must be integers >= 2, got {n_values!r}")
    try:
        generators = [tuple(g) for g in generators]
    except TypeError:
        raise ValueError(f"generators must be (w_max, mu, sigma) triples, got {generators!r}") from None
    if not generators or any(len(g) != 3 for g in generators):
        raise ValueError(f"generators must be a non-empty list of (w_max, mu, sigma) triples, got {generators!r}")
    seeds = list(seeds)
    if not seeds:
        raise ValueError("seeds must hold at least one seed")
    positive("start_distance", start_distance)
    rows = []
    exact = _evaluation(library, "auto") == "exact"
    for w_max, mu, sigma in generators:
        member = library[library.index_of(w_max)]
        # the simulated supervisor judges with the same values the fit reads: exact where the fit is exact
        sup = NoisySupervisor(exact_counterpart(member) if exact else member, mu, sigma)
        for seed in seeds:
            rng = generator(seed, "seeds")
            states = collect_interventions(sup, n_values[-1], rng, start_distance)
            for n in n_values:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", LibraryEdgeWarning)  # recorded in the table instead
                    fit = fit_supervisor(library, states[:n], prior=prior)
                rows.append({"w_max": w_max, "mu": mu, "sigma": sigma, "seed": seed, "n": n, "w_max_hat": fit.w_max,
                             "mu_hat": fit.mu, "sigma_hat": fit.sigma, "recovered": fit.w_max == w_max,
                             "boundary": fit.boundary or ""})
    return pd.DataFrame(rows)


def recovery_summary(table, confidence=0.95):
    """Summarise a :func:`recovery_study` table per (sigma, n), for a table of SIMULATED supervisors.

    Columns: ``data`` ("simulated"), ``sigma``, ``n``, ``runs`` (generators x seeds), ``recovered``
    (fraction choosing the generating ``w_max``) with its Wilson ``confidence`` interval
    (``recovered_ci_low``, ``recovered_ci_high``), ``mean_w_max_error`` with its standard error
    (``w_max_error_se``), ``mean_abs_mu_error`` and ``mean_sigma_ratio`` (``sigma_hat / sigma``).
    """
    needed = {"w_max", "mu", "sigma", "n", "w_max_hat", "mu_hat", "sigma_hat", "recovered"}
    if not isinstance(table, pd.DataFrame) or needed - set(table.columns):
        raise ValueError(f"table must be a recovery_study DataFrame with columns {sorted(needed)}")
    rows = []
    for (sigma, n), part in table.groupby(["sigma", "n"]):
        k, runs = int(part["recovered"].sum()), len(part)
        (low,), (high,) = wilson_interval(k / runs, runs, confidence)
        error = part["w_max_hat"] - part["w_max"]
        rows.append({"data": "simulated", "sigma": sigma, "n": n, "runs": runs, "recovered": k / runs,
                     "recovered_ci_low": low, "recovered_ci_high": high,
                     "mean_w_max_error": error.mean(), "w_max_error_se": error.std(ddof=1) / np.sqrt(runs),
                     "mean_abs_mu_error": (part["mu_hat"] - part["mu"]).abs().mean(),
                     "mean_sigma_ratio": (part["sigma_hat"] / part["sigma"]).mean()})
    return pd.DataFrame(rows)


def data_efficiency_scan(table, n, chosen, share=0.9, table_name=""):
    """Data efficiency read from a :func:`recovery_study` table: for each supervisor (``w_max``, ``sigma``), how
    many sessions of ``n`` interventions recover ``w_max``, and whether at least ``share`` of them do. Returns
    ``(cells, scan)``: the cells as a DataFrame, and the scan in the form of the reproduction report
    (``seeds`` [recovered, sessions] at the ``chosen`` (w_max, sigma), ``settings`` [cells recovering in at least
    ``share`` of sessions, cells], ``flips``: the cells that do not)."""
    if not isinstance(table, pd.DataFrame) or {"w_max", "sigma", "n", "recovered"} - set(table.columns):
        raise ValueError("table must be a recovery_study DataFrame")
    part = table[table["n"] == n]
    if part.empty:
        raise ValueError(f"n: the table has no sessions of {n} interventions (has {sorted(table['n'].unique())})")
    cells = part.groupby(["w_max", "sigma"])["recovered"].agg(recovered="sum", sessions="size").reset_index()
    cells["recovered"] = cells["recovered"].astype(int)
    cells["holds"] = cells["recovered"] >= np.ceil(share * cells["sessions"])
    at = cells[np.isclose(cells["w_max"], chosen[0]) & np.isclose(cells["sigma"], chosen[1])]
    if len(at) != 1:
        raise ValueError(f"chosen: {chosen!r} is not one of the (w_max, sigma) cells")
    flips = "; ".join(f"w_max {r['w_max']:g}, sigma {r['sigma']:g}: {r['recovered']}/{r['sessions']}"
                      for r in cells[~cells["holds"]].to_dict("records"))
    scan = {"table": table_name, "seeds": [int(at["recovered"].iloc[0]), int(at["sessions"].iloc[0])],
            "settings": [int(cells["holds"].sum()), int(len(cells))], "flips": flips}
    return cells, scan
