"""Predictability versus legibility (section 6.6): is legibility ``L = J1 - J0`` correlated with
predictability ``J1`` over sets of motions a reader would recognise?

Over samples from the observer's own model ``P(u | H1)`` the question is empty: when ``J1 - J0``
is affine in ``u`` (equal curvature, eq. (6.17)), ``Cov(J1, J1 - J0) = 0`` for a Gaussian with
precision ``H1`` by construction (``Cov(u'Hu/2 + h'u, a'u) = a' H^-1 (H mu + h) = 0`` at the mean
``mu = -H^-1 h``). :func:`predictability_correlations` therefore measures the correlation over
several motion sets and reports each, that one included.
"""

import numpy as np
import pandas as pd

from ..observer import batch_costs, sample_boltzmann
from .objective import legible_trajectory

MOTION_SETS = ("samples from P(u|H0)", "mixture of P(u|H0) and P(u|H1)", "straight lines to random end points",
               "optima of (1+alpha) J1 - J0 over alpha", "samples from P(u|H1) (zero by construction)")


def motion_sets(dynamics, J1, J0, x0, N, rng, n_samples=2000, end_box=((-2.0, 2.0), (0.0, 2.0)),
                alphas=np.geomspace(0.25, 30.0, 40)):
    """The control sequences of each of :data:`MOTION_SETS` (dict name -> (B, N, m) array).

    Straight lines: constant controls from ``x0`` to end points drawn uniformly in ``end_box``
    (one (low, high) pair per state coordinate; single-integrator dynamics ``x' = u`` assumed for
    "straight"). The mixture draws half of its motions from each hypothesis.
    """
    if not isinstance(n_samples, (int, np.integer)) or n_samples < 3:
        raise ValueError(f"n_samples must be an integer >= 3, got {n_samples!r}")
    box = np.asarray(end_box, float)
    if box.shape != (dynamics.n, 2) or not np.all(np.isfinite(box)) or np.any(box[:, 0] >= box[:, 1]):
        raise ValueError(f"end_box must give a finite (low < high) pair for each of the {dynamics.n} coordinates, "
                         f"got {end_box!r}")
    x0 = np.asarray(x0, float)
    h0 = sample_boltzmann(dynamics, J0, x0, N, n_samples, rng)
    h1 = sample_boltzmann(dynamics, J1, x0, N, n_samples, rng)
    half = n_samples // 2
    mixture = np.concatenate([sample_boltzmann(dynamics, J0, x0, N, half, rng),
                              sample_boltzmann(dynamics, J1, x0, N, n_samples - half, rng)])
    lines = straight_lines(dynamics, x0, N, rng.uniform(box[:, 0], box[:, 1], size=(n_samples, dynamics.n)))
    optima = np.array([legible_trajectory(dynamics, J1, J0, x0, N, a).us for a in alphas])
    return dict(zip(MOTION_SETS, (h0, mixture, lines, optima, h1)))


def straight_lines(dynamics, x0, N, ends):
    """Controls (B, N, m) that move from ``x0`` to each of ``ends`` (B, n) along a straight line at
    constant speed, ``u_k = B^+ (x_{k+1} - A x_k)``; a ValueError if the dynamics cannot follow
    such a line (e.g. a double integrator's velocities)."""
    dyn = dynamics.stages(0, N)
    A, B = np.broadcast_to(dyn.A, (N, dyn.n, dyn.n)), np.broadcast_to(dyn.B, (N, dyn.n, dyn.m))
    s = np.linspace(0.0, 1.0, N + 1)
    xs = x0 + s[None, :, None] * (np.asarray(ends, float)[:, None, :] - x0)      # (B, N+1, n)
    need = xs[:, 1:] - np.einsum("kij,bkj->bki", A, xs[:, :-1])
    us = np.einsum("kij,bkj->bki", np.linalg.pinv(B), need)
    if not np.allclose(np.einsum("kij,bkj->bki", B, us), need, atol=1e-9 * max(1.0, np.abs(need).max())):
        raise ValueError("these dynamics cannot follow a straight line at constant speed (B is not onto)")
    return us


def predictability_correlations(dynamics, J1, J0, x0, N, rng, **kwargs):
    """Pearson correlations ``r(J1, L)`` (L = J1 - J0) and ``r(J1, -J0)`` over each motion set of
    :func:`motion_sets` (keyword arguments go there). A DataFrame with one row per set."""
    rows = []
    for name, us in motion_sets(dynamics, J1, J0, x0, N, rng, **kwargs).items():
        j1, j0 = batch_costs(dynamics, J1, x0, us), batch_costs(dynamics, J0, x0, us)
        rows.append({"motion set": name, "motions": len(us), "r(J1, L)": np.corrcoef(j1, j1 - j0)[0, 1],
                     "r(J1, -J0)": np.corrcoef(j1, -j0)[0, 1], "sd J1": j1.std(), "sd L": (j1 - j0).std()})
    return pd.DataFrame(rows)


def correlated_sets(table, threshold=0.3, exclude=(MOTION_SETS[-1],)):
    """How many motion sets (the rows of :func:`predictability_correlations`, ``exclude``-d ones left
    out) have ``r(J1, L) >= threshold``; the rule fixed for "typically correlated" (section 6.6)."""
    keep = table[~table["motion set"].isin(exclude)]
    return int((keep["r(J1, L)"] >= threshold).sum())


def correlation_scan(dynamics, J1, J0, x0, N, seeds, threshold=0.3, **kwargs):
    """Section 6.6's "typically correlated" over what the thesis leaves open: :func:`predictability_correlations`
    for each seed (``np.random.default_rng(seed)``; keyword arguments go to :func:`motion_sets`). Returns
    ``(by_seed, by_set)``: per seed the number of motion sets (the last, zero by construction, left out) with
    ``r(J1, L) >= threshold``; per motion set the range of ``r`` over the seeds and in how many seeds it
    reaches the threshold."""
    tables = [predictability_correlations(dynamics, J1, J0, x0, N, np.random.default_rng(seed), **kwargs).assign(seed=seed)
              for seed in seeds]
    every = pd.concat(tables, ignore_index=True)
    by_seed = pd.DataFrame({"seed": list(seeds), "sets with r >= threshold": [correlated_sets(t, threshold) for t in tables]})
    by_set = every.groupby("motion set", sort=False)["r(J1, L)"].agg(
        r_min="min", r_max="max", seeds_reaching=lambda r: int((r >= threshold).sum())).reset_index()
    return by_seed, by_set
