"""What the recordings say, on the point-wise model: the aligned demonstrations, their returns, and the
exact log-likelihood of constraint sets, of candidate tightenings and of the temperature.

For a deterministic system the log-likelihood of demonstrations under the constraints C is
sum_i [R_i / tau + log Z_{C,L}(s_L^i) - log Z_{C,0}(s_0^i)] (:mod:`.pointwise`), with R_i = sum_t
r(s_t, u_t) dt the demonstration's return (its recorded controls, else the control of the set whose
step best explains the next state) and log Z_{C,T}(s_T) = w(s_T) / tau when it spans the horizon.
A candidate C+ that every demonstration satisfies gains sum_i [-log F_0(s_0^i) + log F_L(s_L^i)].
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize, minimize_scalar

from . import pointwise as pw
from .occupancy import expected_features
from .mapping import _infer, check_box
from .recordings import align

TEMPERATURE_RANGE = 100.0   # the fitted temperature is searched within [tau / 100, tau * 100] of the file's
TEMPERATURE_TOLERANCE = 0.05   # in log tau: the fitted temperature within 5 %
BATCH = 16                     # candidates scored together


@dataclass(frozen=True, eq=False)
class Demonstrated:
    """Demonstrations on the point-wise model: ``states`` (N, L+1, d) aligned to dt, ``samples`` (n, d) every
    recorded state (wrapped), ``path`` (m, d) the recorded paths with points along each segment, ``returns``
    (N,) R_i (not tempered), ``features`` (N, 2d + m) their summed running features and (when they span the
    horizon) terminal ones, ``starts`` / ``ends`` the moves from s_0 and s_L, ``inferred`` steps whose
    control was inferred, and ``same_cell`` the share of steps that end in the cell they began in."""

    states: np.ndarray
    samples: np.ndarray
    path: np.ndarray
    returns: np.ndarray
    features: np.ndarray
    starts: object
    ends: object
    inferred: int
    same_cell: float

    @property
    def n(self):
        return self.states.shape[0]

    @property
    def steps(self):
        return self.states.shape[1] - 1


def demonstrated(problem, recording, truncate=False):
    """:class:`Demonstrated` of ``recording`` for ``problem`` (module docstring); states outside the box
    are refused naming the file, line and column."""
    from .search import path_points
    states, controls, index = align(recording, problem.dt, truncate)
    check_box(problem.grid, recording, states, index)
    g = problem.grid
    N, L1, n = states.shape
    if L1 - 1 > problem.horizon:
        raise ValueError(f"{recording.source}: the demonstrations span {L1 - 1} steps of dt = {problem.dt:g} s, "
                         f"more than the horizon T = {problem.horizon}; raise [time] horizon or trim them")
    flat = g.wrap(states.reshape(-1, n)).reshape(N, L1, n)
    x, nxt = flat[:, :-1].reshape(-1, n), flat[:, 1:].reshape(-1, n)
    recorded = np.zeros(len(x), dtype=bool) if controls is None else np.isfinite(controls.reshape(len(x), -1)).all(axis=1)
    u = np.empty((len(x), problem.controls.shape[1]))
    if recorded.any():
        u[recorded] = controls.reshape(len(x), -1)[recorded]
    if (~recorded).any():
        u[~recorded] = problem.controls[_infer(problem, x[~recorded], nxt[~recorded])[0]]
    returns = (problem.reward.rate(g, x, u) * problem.dt).reshape(N, L1 - 1).sum(axis=1)
    running = pw.running_features(problem, x, u).reshape(N, L1 - 1, -1).sum(axis=1)
    terminal = problem.reward.errors(g, flat[:, -1]) ** 2 if L1 - 1 == problem.horizon else np.zeros((N, n))
    samples = g.wrap(np.vstack([np.asarray(s, dtype=float) for s in recording.states]))
    paths = [g.wrap(np.asarray(s, dtype=float)) for s in recording.states]
    ends = pw.point_moves(problem, flat[:, -1]) if L1 - 1 < problem.horizon else None
    same = float(np.mean(g.cell_of(x) == g.cell_of(nxt)))
    return Demonstrated(flat, samples, path_points(paths), returns, np.hstack([running, terminal]),
                        pw.point_moves(problem, flat[:, 0]), ends, int((~recorded).sum()), same)


def _demonstrated_rewards(model, data, weights):
    """Each demonstration's reward in the model's units (N,): R_i / tau (+ w(s_T) / tau when it spans the
    horizon), or -features . w for per-feature weights."""
    if np.ndim(weights) == 0:
        end = model.problem.reward.terminal(model.problem.grid, data.states[:, -1]) if data.ends is None else 0.0
        return (data.returns + end) / weights
    return -(data.features @ np.asarray(weights))


def _end_values(model, data, regions, weights, logZ):
    """log Z at the demonstrations' starts (N,) and, for prefixes, at their ends (N,; else 0), one exact step ahead
    of the grid's ``logZ`` (:func:`.pointwise.point_log_values`)."""
    cell_ok = pw.points_allowed(model, regions).any(axis=1)

    def at(moves, t):
        return pw.point_log_values(moves, logZ[t], pw.allowed_moves(regions, moves), cell_ok, weights)
    return at(data.starts, 1), (at(data.ends, data.steps + 1) if data.ends is not None else np.zeros(data.n))


def log_likelihood(model, data, regions, weights, successors=None):
    """``(ll, logZ)``: the demonstrations' exact log-likelihood under ``regions`` with ``weights`` (a
    temperature, or per-feature weights: :func:`.pointwise.move_rewards`) (module docstring; -inf if one of
    them enters a region, or starts where no path of the model keeps out of them and in the box) and log Z_{C,t}
    on the cells (``successors``: see :func:`.pointwise.log_partition`)."""
    if any(r.inside(data.samples).any() for r in regions):
        return -math.inf, None
    logZ = pw.log_partition(model, regions, weights, successors)
    z0, zL = _end_values(model, data, regions, weights, logZ)
    if not np.isfinite(z0).all():
        return -math.inf, logZ
    return float(np.sum(_demonstrated_rewards(model, data, weights) + zL - z0)), logZ


def stranded(model, data, regions=()):
    """The demonstrations (indices) from whose start, or prefix's end, no path of the model keeps in the box
    and out of ``regions`` to the horizon (Z = 0 there: the model cannot follow them, whatever the reward)."""
    z0, zL = _end_values(model, data, regions, 1.0, pw.log_partition(model, regions, 1.0))
    return np.flatnonzero(~np.isfinite(z0) | ~np.isfinite(zL))


def log_likelihood_gradient(model, data, regions, weights, logZ, successors=None):
    """d ll / d weights (2d + m,) for per-feature weights: the model's expected features from the starts,
    less those from the ends (prefixes), less the demonstrations' own (Ziebart's eq. 2.8)."""
    grad = expected_features(model, data.starts, 0, logZ, regions, weights, successors) - data.features.sum(axis=0)
    if data.ends is not None:
        grad -= expected_features(model, data.ends, data.steps, logZ, regions, weights, successors)
    return grad


def candidate_gains(model, data, logZ, regions, candidates, weights):
    """The exact log-likelihood gain (total over demonstrations, (K,)) of adding each of ``candidates`` to
    ``regions`` (module docstring): nan where the grid has no trajectory that respects the candidate from a
    demonstrated start or end (F = 0 there, though the demonstration itself respects it). Scored
    ``BATCH`` candidates at a time (memory: moves x batch)."""
    if len(candidates) > BATCH:
        return np.concatenate([candidate_gains(model, data, logZ, regions, candidates[k:k + BATCH], weights)
                               for k in range(0, len(candidates), BATCH)])
    if not candidates:
        return np.zeros(0)
    L = data.steps
    times = {1} | ({L + 1} if data.ends is not None else set())
    F = pw.satisfaction(model, logZ, regions, candidates, weights, times)
    gains = np.zeros(len(candidates))
    bad = np.zeros(len(candidates), dtype=bool)
    for moves, t, sign in ((data.starts, 1, -1.0), (data.ends, L + 1, 1.0)):
        if moves is None:
            continue
        ratio = pw.point_ratios(model, moves, logZ[t], F[t], regions, candidates, weights)
        bad |= (ratio <= 0).any(axis=0)
        with np.errstate(divide="ignore"):
            gains += sign * np.log(np.maximum(ratio, 1e-300)).sum(axis=0)
    return np.where(bad, np.nan, gains)


def fit_temperature(model, data, regions, around, width=TEMPERATURE_RANGE):
    """The maximum-likelihood temperature under ``regions``, searched in [around / width, around * width]
    (bounded one-dimensional search in log tau). Returns (tau, ll, logZ, at_edge)."""
    lo, hi = math.log(around / width), math.log(around * width)
    cache = {}

    def negative(u):
        ll, logZ = log_likelihood(model, data, regions, math.exp(u))
        cache[u] = (ll, logZ)
        return -ll if np.isfinite(ll) else 1e300

    best = minimize_scalar(negative, bounds=(lo, hi), method="bounded", options={"xatol": TEMPERATURE_TOLERANCE})
    u = float(best.x)
    ll, logZ = cache[u] if u in cache else log_likelihood(model, data, regions, math.exp(u))
    edge = min(u - lo, hi - u) < 3 * TEMPERATURE_TOLERANCE
    return math.exp(u), ll, logZ, bool(edge)


def fit_weights(model, data, regions, start, reference, iterations=40, cap=TEMPERATURE_RANGE):
    """The maximum-likelihood weights of the reward's features (2d + m,) under ``regions`` (maximum-entropy
    inverse optimal control, eq. 2.8: the log-likelihood is concave in them), from ``start``, by L-BFGS-B on
    0 <= weights <= ``cap`` times ``reference`` (a weight 0 there: ``cap`` times 1 % of the largest). The
    cap keeps the estimate finite where the demonstrations sit exactly where a feature is best (all ending
    still on a wall: the weight that pulls them there would grow without end). Returns (weights, ll, logZ)."""
    reference = np.asarray(reference, dtype=float)
    scale = np.where(reference > 0, reference, max(float(reference.max()), 1e-6) * 1e-2)
    cache = {}

    def negative(z):
        w, successors = scale * z, []
        ll, logZ = log_likelihood(model, data, regions, w, successors)
        cache[z.tobytes()] = (ll, logZ)
        if not np.isfinite(ll):
            return 1e300, np.zeros_like(z)
        return -ll, -scale * log_likelihood_gradient(model, data, regions, w, logZ, successors)

    best = minimize(negative, np.clip(np.asarray(start, dtype=float) / scale, 0.0, cap), jac=True, method="L-BFGS-B",
                    bounds=[(0.0, cap)] * start.size, options={"maxiter": iterations, "ftol": 1e-7, "gtol": 1e-5})
    z = best.x
    ll, logZ = cache[z.tobytes()] if z.tobytes() in cache else log_likelihood(model, data, regions, scale * z)
    return scale * z, ll, logZ
