"""The KKT peer's search (:mod:`.kkt`): candidate constraints, their residual fits, the stop rule.

Each round (at most ``ROUNDS``):

1. candidates from the system file's families -- a bound on each side of each coordinate that does
   not wrap, at the recorded extreme; disks and boxes (aspect ratios ``ASPECTS``) centred on a grid
   of the plane (one cell apart), each the largest holding no recorded state, kept when at least
   one cell wide (a disk) or half a cell (a box's half-widths); the best disk and box are refined
   on a grid a quarter cell apart around them;
2. each candidate's multipliers may act only at states within EPSILON of its boundary
   (complementary slackness); its residual is fitted by nonnegative least squares (NNLS) over the
   cost weights and those multipliers, the rows of saturated controls left out (their multipliers
   absorb them);
3. the best candidate by the Bayesian information criterion is fitted exactly with cvxpy (cost
   weights within a factor COST_RANGE of the file's, multipliers >= 0, control-limit multipliers
   >= 0 at the saturated steps) against the fit without it, and accepted if it lowers the BIC:
   rows * log(RSS0 / RSS1) > (multipliers used + its parameters) * log(rows).
"""

import math
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np
import scipy.optimize
import scipy.sparse as sp

from ..regions import Bound, Box, Disk
from .kkt import EPSILON, kkt_model

ROUNDS = 3
ASPECTS = (0.5, 1.0, 2.0)
FINE_ASPECTS = (1 / 3, 0.5, 1.0, 2.0, 3.0)
MAX_ACTIVE = 200         # multipliers per candidate: the states nearest its boundary
COST_RANGE = 2.0         # the cost's uncertainty: each term's weight within a factor 2 of the file's
PRECISION = 1e-10        # residual sums of squares below this share of the cost columns' are solver noise


@dataclass(eq=False)
class Candidate:
    """A constraint ``region`` with ``parameters`` numbers, and its multipliers' residual ``columns``
    (rows, k) at the states within EPSILON of its boundary."""

    region: object
    parameters: int
    columns: np.ndarray


@dataclass(eq=False)
class KKTResult:
    """The accepted ``regions`` in order, a ``note`` on how the search stopped, and per round the
    best candidate with its residuals and BIC change (``rounds``)."""

    regions: list
    note: str
    rounds: list = field(default_factory=list)


def _columns(model, points, gradients):
    """Residual columns (rows, k) of multipliers at states ``points`` [(d, s)] with ``gradients`` (k, n)."""
    return np.stack([model.column(d, s, g) for (d, s), g in zip(points, gradients)], axis=1) \
        if len(points) else np.zeros((model.rows, 0))


def _nearest(distance, limit):
    """Indices (d, s) with s >= 1 of the states whose ``distance`` (N, L+1) to a boundary is within
    ``limit``, at most MAX_ACTIVE of them, nearest first."""
    d = np.where(np.arange(distance.shape[1])[None] >= 1, distance, np.inf)
    flat = np.flatnonzero(d.ravel() <= limit)
    flat = flat[np.argsort(d.ravel()[flat], kind="stable")][:MAX_ACTIVE]
    return [tuple(int(v) for v in np.unravel_index(k, d.shape)) for k in flat]


def bound_candidates(model):
    """A bound at the recorded extreme of each side of each coordinate that does not wrap."""
    grid, x, out = model.problem.grid, model.states, []
    for dim in np.flatnonzero(~np.asarray(grid.periodic)):
        width = grid.high[dim] - grid.low[dim]
        for side, sign in (("upper", 1.0), ("lower", -1.0)):
            value = x[..., dim].max() if side == "upper" else x[..., dim].min()
            points = _nearest(np.abs(x[..., dim] - value), EPSILON * width)
            gradient = np.zeros((len(points), grid.ndim))
            gradient[:, dim] = sign
            out.append(Candidate(Bound(int(dim), side, float(value)), 1, _columns(model, points, gradient)))
    return out


def _plane_scales(model, plane):
    """(the plane's largest cell width, its complementary-slackness tolerance EPSILON x its extent)."""
    grid = model.problem.grid
    width = max(grid.widths_1d(plane[0]).max(), grid.widths_1d(plane[1]).max())
    return width, EPSILON * max(grid.high[plane[0]] - grid.low[plane[0]], grid.high[plane[1]] - grid.low[plane[1]])


def _disk(model, plane, centre):
    width, tolerance = _plane_scales(model, plane)
    p = model.states[..., list(plane)] - centre
    dist = np.linalg.norm(p, axis=-1)
    radius = dist.min()
    if radius < width:
        return None
    points = _nearest(dist - radius, tolerance)
    gradient = np.zeros((len(points), model.states.shape[2]))
    for k, (d, s) in enumerate(points):
        gradient[k, list(plane)] = -p[d, s] / max(dist[d, s], 1e-12)
    return Candidate(Disk(tuple(plane), (float(centre[0]), float(centre[1])), float(radius)), 3,
                     _columns(model, points, gradient))


def _box(model, plane, centre, aspect):
    width, tolerance = _plane_scales(model, plane)
    p = model.states[..., list(plane)] - centre
    shape = np.array([math.sqrt(aspect), 1 / math.sqrt(aspect)])
    scaled = np.abs(p) / shape
    size = scaled.max(axis=-1).min()
    half = size * shape
    if half.min() < 0.5 * width:
        return None
    excess = np.abs(p) - half
    points = _nearest(excess.max(axis=-1), tolerance)
    gradient = np.zeros((len(points), model.states.shape[2]))
    for k, (d, s) in enumerate(points):
        face = int(np.argmax(excess[d, s]))
        gradient[k, plane[face]] = -np.sign(p[d, s, face])
    return Candidate(Box(tuple(plane), tuple(centre - half), tuple(centre + half)), 4, _columns(model, points, gradient))


def obstacle_candidates(model, plane, kind, centres=None, aspects=ASPECTS):
    """Disks or boxes (``kind``) centred at ``centres`` (default: every cell centre of the plane)."""
    grid = model.problem.grid
    if centres is None:
        centres = [np.array([a, b]) for a in grid.centers_1d(plane[0]) for b in grid.centers_1d(plane[1])]
    made = [_disk(model, plane, c) for c in centres] if kind == "disk" else \
        [_box(model, plane, c, a) for c in centres for a in aspects]
    return [c for c in made if c is not None]


def _refined(model, plane, kind, best):
    width, _ = _plane_scales(model, plane)
    centre = np.asarray(best.region.center if kind == "disk" else
                        0.5 * (np.asarray(best.region.low) + np.asarray(best.region.high)))
    offsets = np.arange(-4, 5) * width / 4
    centres = [centre + np.array([a, b]) for a in offsets for b in offsets]
    return obstacle_candidates(model, plane, kind, centres, FINE_ASPECTS)


def screen_rss(model, columns, new=0):
    """The residual sum of squares of a nonnegative least-squares fit (scipy's NNLS) over the cost
    weights (each at least 1 / COST_RANGE; the upper limit is left to :func:`exact_fit`) and the
    multipliers of ``columns`` (>= 0), the rows of saturated controls left out; and how many of the
    last ``new`` multipliers it used."""
    keep = model.saturated == 0
    A = np.hstack([model.G, columns])[keep]
    K = model.G.shape[1]
    b = -model.G[keep].sum(axis=1) / COST_RANGE                 # gamma = 1 / COST_RANGE + x, x >= 0
    x, _ = scipy.optimize.nnls(A, b, maxiter=50 * A.shape[1])
    r = A @ x - b
    return float(r @ r), int(np.sum(x[x.size - new:] > 1e-9 * (1 / COST_RANGE + x[:K].max()))) if new else 0


def exact_fit(model, columns, new=0):
    """(RSS, multipliers used among the last ``new`` columns, gamma) of the KKT residual least squares
    solved with cvxpy (module docstring): cost weights in [1 / COST_RANGE, COST_RANGE], multipliers
    >= 0, control-limit multipliers >= 0 at the saturated steps."""
    K, k = model.G.shape[1], columns.shape[1]
    gamma, lam = cp.Variable(K), cp.Variable(k, nonneg=True)
    rows = np.flatnonzero(model.saturated)
    S = sp.csr_matrix((model.saturated[rows], (rows, np.arange(rows.size))), shape=(model.rows, rows.size))
    mu = cp.Variable(rows.size, nonneg=True)
    residual = model.G @ gamma + (columns @ lam if k else 0) + (S @ mu if rows.size else 0)
    cp.Problem(cp.Minimize(cp.sum_squares(residual)), [gamma >= 1 / COST_RANGE, gamma <= COST_RANGE]).solve(
        solver=cp.CLARABEL)
    r = model.G @ gamma.value + (columns @ lam.value if k else 0) + (S @ mu.value if rows.size else 0)
    used = int(np.sum(lam.value[k - new:] > 1e-6 * gamma.value.max())) if new else 0
    return float(r @ r), used, gamma.value


def bic_gain(rows, rss0, rss1, used, parameters, floor):
    """rows log(RSS0 / RSS1) - (multipliers used + parameters) log(rows): > 0 favours the constraint.
    Residuals below ``floor`` (the solvers' precision) count as ``floor``: an exact fit is not improved."""
    return rows * math.log(max(rss0, floor) / max(rss1, floor)) - (used + parameters) * math.log(rows)


def _candidates(model, families, plane, taken):
    out = bound_candidates(model) if "bound" in families else []
    for kind in ("disk", "box"):
        if kind in families:
            found = obstacle_candidates(model, plane, kind)
            if found:
                best = max(found, key=lambda c: -screen_rss(model, np.hstack([taken, c.columns]))[0])
                found += _refined(model, plane, kind, best)
            out += found
    return out


def kkt_inference(spec, recording, rounds=ROUNDS):
    """Constraints of the system file ``spec``'s families (its [candidates]) from ``recording`` by
    the KKT conditions (module docstring): a :class:`KKTResult`."""
    model = kkt_model(spec.problem, recording)
    families, plane = spec.candidates["families"], spec.candidates["plane"]
    taken, accepted, log = np.zeros((model.rows, 0)), [], []
    rows = int(np.sum(model.saturated == 0))
    floor = PRECISION * float(np.sum(model.G ** 2))
    for _ in range(rounds):
        base, _ = screen_rss(model, taken)
        fresh = [c for c in _candidates(model, families, plane, taken) if c.region not in accepted]
        scored = [(c, *screen_rss(model, np.hstack([taken, c.columns]), c.columns.shape[1])) for c in fresh]
        scored = [(bic_gain(rows, base, rss, used, c.parameters, floor), c) for c, rss, used in scored]
        if not scored:
            return KKTResult(accepted, "no candidate", log)
        _, best = max(scored, key=lambda item: item[0])
        rss0, _, _ = exact_fit(model, taken)
        rss1, used, gamma = exact_fit(model, np.hstack([taken, best.columns]), best.columns.shape[1])
        gain = bic_gain(model.rows, rss0, rss1, used, best.parameters, floor)
        log.append({"candidate": best.region, "rss0": rss0, "rss1": rss1, "multipliers": used, "bic_gain": gain,
                    "gamma": dict(zip(model.terms, np.round(gamma, 3)))})
        if gain <= 0:
            return KKTResult(accepted, f"stopped: the best candidate does not lower the BIC ({gain:.1f})", log)
        accepted.append(best.region)
        taken = np.hstack([taken, best.columns])
    return KKTResult(accepted, f"stopped after {rounds} rounds", log)
