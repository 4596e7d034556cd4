"""The maximum-likelihood safe set of a supervisor from their interventions (Sec. 4.4,
eqs. 4.8-4.12): the library member, margin ``mu`` and noise ``sigma`` that make the observed
intervention states most likely; and how often it recovers simulated supervisors."""

import functools
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .dubins import TRUE_W_MAX, check_states
from .reachability import ValueLibrary, unsafe_set_contains
from .supervisor import approach_scenes, NoisySupervisor


@dataclass(frozen=True, eq=False)
class SupervisorFit:
    """The fitted supervisor: the chosen member (eq. 4.12) with its ``mu*``, ``sigma*`` (eq. 4.8).

    Per-member arrays: ``mus``, ``sigmas`` and ``logliks`` (log of eq. 4.9; ``-inf`` where the
    prior excludes the member), ``admissible`` (the prior's support).
    """
    library: ValueLibrary
    index: int
    mus: np.ndarray
    sigmas: np.ndarray
    logliks: np.ndarray
    admissible: np.ndarray
    n: int
    prior: str

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
        return self.mu + k * self.sigma

    def coverage(self, states, k=2.0):
        """Fraction of intervention ``states`` at or below ``alpha = mu + k sigma`` of the fitted member:
        the interventions a robot avoiding at ``alpha`` keeps clear of (Sec. 4.5; ~Phi(k) in expectation)."""
        return float(np.mean(self.value_fn.interp(states) <= self.level(k)))


def gaussian_mle(values):
    """Eq. (4.8)-(4.9) per row of ``values`` (b, p): ``mu*``, ``sigma*`` and ``log L*``."""
    v = np.asarray(values, dtype=float)
    mu = v.mean(axis=-1)
    var = v.var(axis=-1)
    return mu, np.sqrt(var), _max_loglik(var, v.shape[-1])


def _max_loglik(var, p):
    """``log L*`` of eq. (4.9): with ``sigma^2`` the mean squared deviation, the exponent is ``-p/2``."""
    return -0.5 * p * (np.log(2 * np.pi * var) + 1)


@functools.lru_cache(maxsize=32)
def _conservative_members(library, reference):
    return np.array([unsafe_set_contains(member, reference) for member in library])


def fit_supervisor(library, states, prior="mle", reference=None):
    """Fit the supervisor's safe set to intervention ``states`` (n, 3): eq. (4.8), (4.9), (4.12).

    ``prior="mle"``: the argmax of the maximised likelihood over the library. ``prior="map"``: the MAP
    estimate of Sec. 4.4 -- only members whose unsafe sets contain the ``reference`` (true dynamics;
    default the library member with ``w_max = 1``) unsafe set, and ``mu* = max(mu*, 0)`` with
    ``sigma*^2`` the mean squared deviation about it. Raises ValueError for fewer than two
    interventions, NaN, states outside the grid, or zero variance (an unbounded likelihood).
    """
    if not isinstance(library, ValueLibrary):
        raise ValueError("library must be a mutual.supervision.reachability.ValueLibrary")
    if prior not in ("mle", "map"):
        raise ValueError(f"prior must be 'mle' or 'map', got {prior!r}")
    s = check_states(states)
    if len(s) < 2:
        raise ValueError(f"states must hold at least two interventions to estimate mu and sigma, got {len(s)}")
    values = library.interp_all(s)
    outside = np.isnan(values[0])
    if outside.any():
        raise ValueError(f"{outside.sum()} intervention states lie outside the library's grid "
                         f"(|x|, |y| <= {library.grid_spec.half_width}), e.g. {s[outside][0].tolist()}")
    mus = values.mean(axis=1)
    if prior == "map":
        reference = library[library.index_of(TRUE_W_MAX)] if reference is None else reference
        admissible = _conservative_members(library, reference)
        if not admissible.any():
            raise ValueError("no library member's unsafe set contains the reference unsafe set (MAP prior empty)")
        mus = np.maximum(mus, 0.0)
    else:
        admissible = np.ones(len(library), dtype=bool)
    var = np.mean((values - mus[:, None]) ** 2, axis=1)
    if np.any(var[admissible] <= 0):
        bad = library.w_maxes[admissible & (var <= 0)]
        raise ValueError(f"interventions have zero variance under w_max={bad.tolist()}: the likelihood is "
                         "unbounded; states must be distinct")
    with np.errstate(divide="ignore"):
        logliks = np.where(admissible, _max_loglik(var, len(s)), -np.inf)
    return SupervisorFit(library, int(np.argmax(logliks)), mus, np.sqrt(var), logliks, admissible, len(s), prior)


def recovery_study(library, generators, n_values, seeds, start_distance, prior="mle"):
    """How often the estimator recovers simulated noisy supervisors (Sec. 4.3-4.4).

    ``generators``: ``(w_max, mu, sigma)`` triples (``w_max`` a library member). For each generator
    and seed, a supervisor watches Phase II ``approach_scenes`` until it has intervened
    ``max(n_values)`` times; the fit uses its first ``n`` interventions. One row per
    (generator, seed, n): the estimates and whether ``w_max`` was recovered exactly.
    """
    n_values = sorted(int(n) for n in n_values)
    if not n_values or n_values[0] < 2:
        raise ValueError(f"n_values must be integers >= 2, got {n_values!r}")
    rows = []
    for w_max, mu, sigma in generators:
        sup = NoisySupervisor(library[library.index_of(w_max)], mu, sigma)
        for seed in seeds:
            rng = np.random.default_rng(seed)
            states = np.empty((0, 3))
            while len(states) < n_values[-1]:
                more, _ = sup.first_interventions(
                    approach_scenes(2 * n_values[-1], rng, library.obstacle_radius, start_distance), rng)
                states = np.vstack([states, more])
            for n in n_values:
                fit = fit_supervisor(library, states[:n], prior=prior)
                rows.append({"w_max": w_max, "mu": mu, "sigma": sigma, "seed": seed, "n": n, "w_max_hat": fit.w_max,
                             "mu_hat": fit.mu, "sigma_hat": fit.sigma, "recovered": fit.w_max == w_max})
    return pd.DataFrame(rows)
