"""The KKT peer's search (:mod:`.kkt`): candidate constraints, their residual fits, the stop rule.

Each round (at most ``ROUNDS``):

1. candidates from the system file's families -- a bound on each side of each coordinate that does
   not wrap, at the recorded extreme; disks and boxes (aspect ratios ``ASPECTS``) centred on a grid
   of the plane (two cells apart), each the largest holding no recorded state, kept when at least
   one cell wide (a disk) or half a cell (a box's half-widths); the best disk and box are refined
   on a grid a quarter cell apart (aspect ratios ``FINE_ASPECTS``) around them, and the best of those
   polished by Nelder-Mead over its centre (and a box's aspect ratio);
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
SHORTLIST = 8           # candidates refitted with the cost weights free after the quick ranking
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


def _nearest(distance, limit, cuts):
    """Indices (d, s) with s >= 1 and s not a window end (``cuts`` (N, L+1)) of the states whose ``distance``
    (N, L+1) to a boundary is within ``limit``, at most MAX_ACTIVE of them, nearest first."""
    d = np.where((np.arange(distance.shape[1]) >= 1)[None] & ~cuts, distance, np.inf)
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
            points = _nearest(np.abs(x[..., dim] - value), EPSILON * width, model.cuts)
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
    points = _nearest(dist - radius, tolerance, model.cuts)
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
    points = _nearest(excess.max(axis=-1), tolerance, model.cuts)
    gradient = np.zeros((len(points), model.states.shape[2]))
    for k, (d, s) in enumerate(points):
        face = int(np.argmax(excess[d, s]))
        gradient[k, plane[face]] = -np.sign(p[d, s, face])
    return Candidate(Box(tuple(plane), tuple(centre - half), tuple(centre + half)), 4, _columns(model, points, gradient))


def obstacle_candidates(model, plane, kind, centres=None, aspects=ASPECTS):
    """Disks or boxes (``kind``) centred at ``centres`` (default: every other cell centre of the plane)."""
    grid = model.problem.grid
    if centres is None:
        centres = [np.array([a, b]) for a in grid.centers_1d(plane[0])[::2] for b in grid.centers_1d(plane[1])[::2]]
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


class Screen:
    """Fast fits for ranking candidates: the rows of saturated controls left out (their multipliers
    absorb them), the free costates projected out window by window, the cost weights at least
    1 / COST_RANGE (the upper limit is left to :func:`exact_fit`), everything else >= 0 (scipy's NNLS)."""

    def __init__(self, model):
        self.keep = np.flatnonzero(model.saturated == 0)
        self.K = model.G.shape[1]
        window = model.window[self.keep]
        self.block_of = np.full(self.keep.size, -1)            # kept row -> its block of free costates
        self.blocks = []
        for w in np.unique(window):
            rows = np.flatnonzero(window == w)
            F = model.free[self.keep[rows]]
            F = F[:, np.abs(F).sum(axis=0) > 0]
            if F.shape[1]:
                q, r = np.linalg.qr(F)
                q = q[:, np.abs(np.diag(r)) > 1e-10 * np.abs(r).max()]
                self.block_of[rows] = len(self.blocks)
                self.blocks.append((rows, q))
        self.G = self.project(model.G[self.keep])
        self.b = -self.G.sum(axis=1) / COST_RANGE                # gamma = 1 / COST_RANGE + x, x >= 0

    @property
    def rows(self):
        return self.keep.size

    def project(self, M):
        """``M`` (kept rows, k) with the span of the free costates removed."""
        M = np.array(M, dtype=float)
        touched = self.block_of[np.abs(M).sum(axis=1) > 0]
        for b in np.unique(touched[touched >= 0]):
            rows, q = self.blocks[b]
            M[rows] -= q @ (q.T @ M[rows])
        return M

    def columns(self, model, columns):
        return self.project(columns[self.keep])

    def fit(self, columns):
        """(RSS, residual, multipliers used) of the cost weights and the (projected) ``columns``."""
        A = np.hstack([self.G, columns])
        x, _ = scipy.optimize.nnls(A, self.b, maxiter=50 * A.shape[1])
        r = A @ x - self.b
        return float(r @ r), r, int(np.sum(x[self.K:] > 1e-9 * (1 / COST_RANGE + x[:self.K].max())))

    def added(self, residual, columns):
        """(RSS, multipliers used) of the residual with the (projected) ``columns`` added, the rest held."""
        if not columns.shape[1]:
            return float(residual @ residual), 0
        x, rnorm = scipy.optimize.nnls(columns, -residual, maxiter=50 * columns.shape[1])
        return float(rnorm ** 2), int(np.sum(x > 1e-9 * max(x.max(), 1e-300)))


def exact_fit(model, columns, new=0):
    """(RSS, multipliers used among the last ``new`` columns, gamma) of the KKT residual least squares
    solved with cvxpy (module docstring): cost weights in [1 / COST_RANGE, COST_RANGE], multipliers
    >= 0, control-limit multipliers >= 0 at the saturated steps, the windows' end costates free."""
    K, k = model.G.shape[1], columns.shape[1]
    gamma, lam = cp.Variable(K), cp.Variable(k, nonneg=True)
    rows = np.flatnonzero(model.saturated)
    S = sp.csr_matrix((model.saturated[rows], (rows, np.arange(rows.size))), shape=(model.rows, rows.size))
    mu, nu = cp.Variable(rows.size, nonneg=True), cp.Variable(model.free.shape[1])
    parts = [(model.G, gamma), (columns, lam), (S, mu), (sp.csr_matrix(model.free), nu)]
    residual = sum(M @ v for M, v in parts if M.shape[1])
    cp.Problem(cp.Minimize(cp.sum_squares(residual)), [gamma >= 1 / COST_RANGE, gamma <= COST_RANGE]).solve(
        solver=cp.CLARABEL)
    r = sum(M @ v.value for M, v in parts if M.shape[1])
    used = int(np.sum(lam.value[k - new:] > 1e-6 * gamma.value.max())) if new else 0
    return float(r @ r), used, gamma.value


def bic_gain(rows, rss0, rss1, used, parameters, floor):
    """rows log(RSS0 / RSS1) - (multipliers used + parameters) log(rows): > 0 favours the constraint.
    Residuals below ``floor`` (the solvers' precision) count as ``floor``: an exact fit is not improved."""
    return rows * math.log(max(rss0, floor) / max(rss1, floor)) - (used + parameters) * math.log(rows)


def _polished(screen, model, plane, kind, start, taken):
    """The obstacle of ``kind`` whose centre (and, for a box, log aspect ratio) minimises the screened
    residual, by Nelder-Mead from the ``start`` candidate (the parameters are continuous)."""
    region = start.region
    if kind == "disk":
        x0 = np.asarray(region.center, dtype=float)
        make = lambda v: _disk(model, plane, v)
    else:
        half = 0.5 * (np.asarray(region.high) - np.asarray(region.low))
        x0 = np.r_[0.5 * (np.asarray(region.low) + np.asarray(region.high)), math.log(half[0] / half[1])]
        make = lambda v: _box(model, plane, v[:2], math.exp(v[2]))

    def rss(v):
        c = make(v)
        return math.inf if c is None else screen.fit(np.hstack([taken, screen.columns(model, c.columns)]))[0]

    width, _ = _plane_scales(model, plane)
    simplex = np.vstack([x0] + [x0 + 0.25 * width * e for e in np.eye(x0.size)])
    out = scipy.optimize.minimize(rss, x0, method="Nelder-Mead",
                                  options={"initial_simplex": simplex, "xatol": 1e-3, "fatol": 0.0, "maxfev": 150})
    return make(out.x)


def _candidates(model, families, plane):
    out = bound_candidates(model) if "bound" in families else []
    for kind in ("disk", "box"):
        if kind in families:
            out += obstacle_candidates(model, plane, kind)
    return out


def _ranked(screen, model, candidates, taken, base, floor):
    """(BIC gain, candidate) pairs, best first: every candidate ranked by adding its multipliers to the
    fit without it, the best SHORTLIST refitted with the cost weights free again."""
    rss0, r0, _ = base
    quick = []
    for c in candidates:
        rss, used = screen.added(r0, screen.columns(model, c.columns))
        quick.append((bic_gain(screen.rows, rss0, rss, used, c.parameters, floor), c))
    quick.sort(key=lambda item: -item[0])
    full = []
    for _, c in quick[:SHORTLIST]:
        rss, _, used = screen.fit(np.hstack([taken, screen.columns(model, c.columns)]))
        used = min(used, c.columns.shape[1])
        full.append((bic_gain(screen.rows, rss0, rss, used, c.parameters, floor), c))
    return sorted(full, key=lambda item: -item[0])


def kkt_inference(spec, recording, rounds=ROUNDS):
    """Constraints of the system file ``spec``'s families (its [candidates]) from ``recording`` by
    the KKT conditions (module docstring): a :class:`KKTResult`."""
    model = kkt_model(spec.problem, recording)
    screen = Screen(model)
    families, plane = spec.candidates["families"], spec.candidates["plane"]
    taken, taken_screen, accepted, log = np.zeros((model.rows, 0)), np.zeros((screen.rows, 0)), [], []
    floor = PRECISION * float(np.sum(model.G ** 2))
    for _ in range(rounds):
        base = screen.fit(taken_screen)
        found = [c for c in _candidates(model, families, plane) if c.region not in accepted]
        ranked = _ranked(screen, model, found, taken_screen, base, floor)
        for kind in ("disk", "box"):                     # refine the best obstacle of each kind
            best = next((c for _, c in ranked if c.region.kind == kind), None)
            if best is not None:
                finer = _refined(model, plane, kind, best)
                finer.append(_polished(screen, model, plane, kind, max(finer, key=lambda c: -screen.fit(
                    np.hstack([taken_screen, screen.columns(model, c.columns)]))[0]), taken_screen))
                ranked = _ranked(screen, model, [c for _, c in ranked] + [c for c in finer if c is not None],
                                 taken_screen, base, floor)
        if not ranked:
            return KKTResult(accepted, "no candidate", log)
        best = ranked[0][1]
        rss0, _, _ = exact_fit(model, taken)
        rss1, used, gamma = exact_fit(model, np.hstack([taken, best.columns]), best.columns.shape[1])
        gain = bic_gain(model.rows, rss0, rss1, used, best.parameters, floor)
        log.append({"candidate": best.region, "rss0": rss0, "rss1": rss1, "multipliers": used, "bic_gain": gain,
                    "gamma": dict(zip(model.terms, np.round(gamma, 3)))})
        if gain <= 0:
            return KKTResult(accepted, f"stopped: the best candidate does not lower the BIC ({gain:.1f})", log)
        accepted.append(best.region)
        taken = np.hstack([taken, best.columns])
        taken_screen = np.hstack([taken_screen, screen.columns(model, best.columns)])
    return KKTResult(accepted, f"stopped after {rounds} rounds", log)
