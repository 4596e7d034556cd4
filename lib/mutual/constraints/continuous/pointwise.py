"""The partition function of a deterministic continuous system, point by point: the exact likelihood of
continuous demonstrations, with Z approximated on the grid.

**Why not the grid MDP.** Discretizing x' = f(x, u) into S(x, a, x') (:mod:`.discretization`) turns a
deterministic system into a stochastic one: the points of a cell land in several cells. Chapter 2's
causal backup (eqs. 2.19-2.21: E_{x'} V inside the exponential) then models a demonstrator that does not
know where in its cell it is, and chapter 3's chance constraint must let each action risk what the whole
cell risks. That is where the information of continuous demonstrations is lost: eq. (3.3) sets psi to the
largest chance with which a demonstrated *cell* and action enter the region, so a bound between the
demonstrations and the truth gets a large psi (the demonstrated cell next to it leaks into it), Lemma
3.2.1 raises it further until no cell nearby is left without an allowed action (often to psi = 1:
it forbids nothing), and the grid likelihood charges every demonstrated step near the boundary for a
risk the demonstrator, who knew its state, never ran.

**The model here.** The demonstrator knows its continuous state s and the dynamics are deterministic:

    Z_T(s) = exp(w(s)/tau) Phi_C(s),    Z_t(s) = sum_a Phi_C(s, a) exp(r(s, a) dt/tau) Z_{t+1}(f(s, a)),

with Phi_C(s, a) = 1 when neither s, f(s, a) nor the segment between them enters a forbidden region and
f(s, a) stays in the state box (eq. 3.1 with psi = 0: on a deterministic transition the chance of entering is 0 or 1, and eq. 3.3 on the
continuous demonstrations gives exactly psi* = 0). The policy is pi(a | s) = Phi exp(r) Z_{t+1}(f(s, a)) /
Z_t(s) (eq. 2.19), so the log-likelihood of a demonstration telescopes to R(xi)/tau + log Z_L(s_L) -
log Z_0(s_0) when it satisfies C (-inf otherwise), and a tightening C -> C+ that the demonstrations
satisfy gains exactly -log F_0(s_0) + log F_L(s_L) with F = Z_{C+}/Z_C (eq. 2.25 is exact for
deterministic dynamics; F_L = 1 when the demonstration spans the horizon).

**The box is known.** Recordings must lie in the state box (``[state] low``/``high`` on the coordinates that
do not wrap), so the modelled demonstrator stays in it too: a move whose successor leaves the box is not
allowed, as one that enters a region is not. Clipping it onto the box instead would let the model leave where
the demonstrator never could, and a bound at the box's edge would then gain what the box itself explains.

**On the grid** Z_t is represented by averages over the *allowed* points of each cell: with the
"sample" scheme the mean over the cell's ``samples`` points s_k outside every region of
sum_a Phi exp(r(s_k, a)) Z_{t+1}(f(s_k, a)); with "barycentric" the cell centre, Z_{t+1} interpolated
linearly at f(centre, a) over the Kuhn simplex's allowed vertices (weights renormalized; a successor in the
box but beyond the outermost centres takes the value at the nearest of them). Z jumps to 0 at a
region's boundary; a plain cell average would mix the 0 of the points inside into the value of a
successor that lies outside, and so charge every path that passes within a cell of a region for it --
every candidate here touches the demonstrations, so that charge would inflate every gain. Both schemes
are linear in Z; :func:`log_partition` runs in log space, :func:`satisfaction` carries the ratio
F = Z_{C+}/Z_C (Theorem 2.3.1's F with deterministic successors: F_t = E_{a ~ pi_C}[Phi_{C+} F_{t+1}(f(s, a))]).
At continuous points (the demonstrations' starts and ends) the values are one exact step ahead of the grid.
"""

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ... import budget
from .discretization import kuhn_weights
from .logspace import log0, logsumexp, logsumexp_rows, probabilities, ratio

SEGMENT_POINTS = 3      # interior points at which a move's straight segment is checked against obstacles
KEPT_SETS = 4           # constraint sets whose allowed moves are kept on the moves (:func:`allowed_moves`)
KEEP_BYTES = 2 ** 28   # at most this much of log Z at the successors is kept between the value and its gradient


@dataclass(frozen=True, eq=False)
class Moves:
    """One step of ``dt`` from points under every control, ``fan`` moves per owner (a cell's samples times
    the controls, or a point's controls), owner by owner: ``point`` and ``successor`` (P, d), ``reward``
    (P,) r(point, u) dt (not tempered), the successor on the grid: ``target`` (P, k) cells with
    ``log_weight`` (P, k) (k = 1: its cell, log 1; barycentric: the d + 1 vertices and log weights), and
    ``features`` (P, d + m): the reward's features e_i^2 dt and u_j^2 dt (r = -features . weights), and
    ``in_box`` (P,) whether the successor lies in the state box (module docstring)."""

    point: np.ndarray
    successor: np.ndarray
    reward: np.ndarray
    target: np.ndarray
    log_weight: np.ndarray
    fan: int
    features: np.ndarray
    in_box: np.ndarray

    @property
    def n_moves(self):
        return self.reward.size

    @property
    def n_owners(self):
        return self.reward.size // self.fan

    @cached_property
    def allowed_kept(self):
        """:func:`allowed_moves` of the last few constraint sets (a dict, oldest first)."""
        return {}

    @cached_property
    def by_vertex(self):
        """``target`` and ``log_weight`` vertex by vertex, (k, P) each, contiguous: what the backups read (a second
        copy, kept with the model: about 10 MB for the cart-pole's 12^4 cells)."""
        return np.ascontiguousarray(self.target.T), np.ascontiguousarray(self.log_weight.T)


@dataclass(frozen=True, eq=False)
class PointModel:
    """The grid's cells as points: ``moves`` of every cell (cell by cell), ``points`` (X, M, d) the points a
    cell stands for, ``terminal`` (X, M) w at them (not tempered) and ``terminal_features`` (X, M, d) e_i^2."""

    problem: object
    moves: Moves
    points: np.ndarray
    terminal: np.ndarray
    terminal_features: np.ndarray

    @property
    def horizon(self):
        return int(self.problem.horizon)


def running_features(problem, x, u):
    """The quadratic reward's running features (N, d + m): e_i^2 dt and u_j^2 dt (r dt = -features . (q, c))."""
    return np.hstack([problem.reward.errors(problem.grid, x) ** 2, np.asarray(u, dtype=float) ** 2]) * problem.dt


def file_weights(problem, temperature=None):
    """The weights (2d + m,) of the running and terminal features that give ``problem``'s reward divided by
    ``temperature`` (default the file's): (q, c, Q) / tau."""
    r = problem.reward
    tau = r.temperature if temperature is None else temperature
    return np.concatenate([r.state_weights, r.control_weights, r.terminal_weights]) / tau


def _moves(problem, point, successor, fan):
    """Moves point -> successor (controls varying fastest) with their successors on the grid."""
    g, m = problem.grid, problem.controls.shape[1]
    controls = np.broadcast_to(problem.controls[None], (point.shape[0] // problem.n_actions, problem.n_actions, m))
    features = running_features(problem, point, controls.reshape(-1, m))
    reward = -features @ np.concatenate([problem.reward.state_weights, problem.reward.control_weights])
    in_box = ~g.outside(successor).any(axis=1)
    if problem.scheme == "barycentric":
        vertices, weights = kuhn_weights(g, successor)
        with np.errstate(divide="ignore"):
            return Moves(point, successor, reward, vertices, np.log(weights), fan, features, in_box)
    return Moves(point, successor, reward, g.cell_of(successor)[:, None], np.zeros((point.shape[0], 1)), fan, features,
                 in_box)


def point_model(problem, progress=None):
    """The :class:`PointModel` of ``problem`` (module docstring): the sample scheme draws ``samples``
    points per cell (seeded by ``problem.seed``); barycentric uses the centres. ``progress(done, total)``
    is called as blocks of cells are integrated."""
    g, A = problem.grid, problem.n_actions
    M = problem.samples if problem.scheme == "sample" else 1
    budget.check(budget.discretization(g.shape, A, M, problem.scheme))
    rng = np.random.default_rng([problem.seed, 7])
    if problem.scheme == "sample":
        low, width = g.cell_boxes(np.arange(g.n_cells))
        points = low[:, None, :] + rng.random((g.n_cells, M, g.ndim)) * width[:, None, :]
    else:
        points = g.centers()[:, None, :]
    parts, block = [], max(1, 2 ** 18 // (A * M))
    for start in range(0, g.n_cells, block):
        cells = np.arange(start, min(start + block, g.n_cells))
        x = np.repeat(points[cells].reshape(-1, g.ndim), A, axis=0)      # (cell, sample, control)
        successor = problem.step(x, np.tile(problem.controls, (cells.size * M, 1)))
        parts.append(_moves(problem, x, successor, A * M))
        if progress is not None:
            progress(int(cells[-1]) + 1, g.n_cells)
    joined = {f: np.concatenate([getattr(p, f) for p in parts])
              for f in ("point", "successor", "reward", "target", "log_weight", "features", "in_box")}
    moves = Moves(fan=A * M, **joined)
    flat = points.reshape(-1, g.ndim)
    terminal = problem.reward.terminal(g, flat).reshape(g.n_cells, M)
    terminal_features = (problem.reward.errors(g, flat) ** 2).reshape(g.n_cells, M, g.ndim)
    return PointModel(problem, moves, points, terminal, terminal_features)


def point_moves(problem, points):
    """:class:`Moves` from continuous ``points`` (N, d) under every control."""
    g, A = problem.grid, problem.n_actions
    points = g.wrap(np.atleast_2d(np.asarray(points, dtype=float)))
    x = np.repeat(points, A, axis=0)
    return _moves(problem, x, problem.step(x, np.tile(problem.controls, (len(points), 1))), A)


def allowed_moves(regions, moves):
    """Phi_C per move (P,; read-only): the move's successor lies in the box, and its point, successor and segment
    outside every region. Kept on ``moves`` for the last ``KEPT_SETS`` constraint sets computed: a reward fit
    evaluates one set about a hundred times."""
    regions, kept = tuple(regions), moves.allowed_kept
    try:
        if regions in kept:
            return kept[regions]
        keep = True
    except TypeError:       # a region with an unhashable field (a list): computed, not kept
        keep = False
    ok = moves.in_box.copy()
    for region in regions:
        ok &= ~blocked(region, moves.point, moves.successor)
    ok.flags.writeable = False
    if keep:
        if len(kept) >= KEPT_SETS:
            del kept[next(iter(kept))]
        kept[regions] = ok
    return ok


def blocked(region, p, q):
    """Whether the moves p -> q (N, d) enter ``region``: at either end, or (obstacles) on the segment."""
    hit = region.inside(p) | region.inside(q)
    if getattr(region, "kind", "") in ("disk", "box"):
        for k in range(1, SEGMENT_POINTS + 1):
            s = k / (SEGMENT_POINTS + 1)
            hit |= region.inside(p + s * (q - p))
    return hit


def move_rewards(moves, weights):
    """The moves' rewards in the model's units: ``weights`` is a temperature tau (a number: r dt / tau) or
    per-feature weights (2d + m,) (-features . w; the first d + m weigh the running features)."""
    if np.ndim(weights) == 0:
        return moves.reward / weights
    return -(moves.features @ np.asarray(weights)[:moves.features.shape[1]])


def terminal_rewards(model, weights):
    """w / tau at the cells' points (X, M), or -e^2 . (the last d of the per-feature ``weights``)."""
    if np.ndim(weights) == 0:
        return model.terminal / weights
    return -(model.terminal_features @ np.asarray(weights)[-model.terminal_features.shape[2]:])


def by_owner(moves, values):
    """``values`` (P, ...) reshaped to (owners, fan, ...)."""
    return values.reshape((moves.n_owners, moves.fan) + values.shape[1:])


def points_allowed(model, regions):
    """(X, M) booleans: the cells' points that lie outside every region."""
    pts = model.points.reshape(-1, model.points.shape[2])
    ok = np.ones(len(pts), dtype=bool)
    for region in regions:
        ok &= ~region.inside(pts)
    return ok.reshape(model.points.shape[:2])


def successor_norm(moves, cell_ok):
    """-log of the interpolation weight (P,) on each successor's allowed vertices (barycentric; -inf where
    none is allowed), or None (sample scheme): what :func:`successor_log_values` renormalizes by, the same
    at every time step."""
    if moves.target.shape[1] == 1:
        return None
    weight = (np.exp(moves.log_weight) * cell_ok[moves.target]).sum(axis=1)
    return np.where(weight > 0, -log0(np.maximum(weight, 1e-300)), -np.inf)


def successor_log_values(moves, logZ_next, cell_ok, norm=None):
    """log Z_{t+1} at every move's successor (P,): its cell's value (sample scheme), or the interpolation
    over the allowed vertices with their weights renormalized (barycentric); ``cell_ok`` (X,): cells with
    an allowed point; ``norm``: :func:`successor_norm`, if computed already."""
    if moves.target.shape[1] == 1:
        return logZ_next[moves.target[:, 0]]
    target, log_weight = moves.by_vertex
    value = logsumexp_rows([w + logZ_next[v] for v, w in zip(target, log_weight)])
    return value + (successor_norm(moves, cell_ok) if norm is None else norm)


def log_partition(model, regions=(), weights=1.0, successors=None):
    """log Z_{C,t} (T+1, X) on the cells for the constraint set ``regions`` (module docstring). On the
    barycentric scheme a list ``successors`` receives, at index t, the successors' log Z_{t+1}
    (:func:`successor_log_values`, an interpolation worth keeping when they fit in ``KEEP_BYTES``), for
    :func:`.occupancy.expected_features` to reuse."""
    mv = model.moves
    ok = points_allowed(model, regions)
    n_ok, cell_ok = ok.sum(axis=1), ok.any(axis=1)
    norm = successor_norm(mv, cell_ok)
    move_reward = np.where(allowed_moves(regions, mv), move_rewards(mv, weights), -np.inf)
    logZ = np.empty((model.horizon + 1, ok.shape[0]))
    logZ[-1] = _terminal(model, ok, weights)
    keep = successors is not None and norm is not None and mv.target.shape[0] * model.horizon * 8 <= KEEP_BYTES
    if successors is not None:  # emptied when not kept, so a list passed again never holds another call's values
        successors[:] = [None] * model.horizon if keep else []
    for t in range(model.horizon - 1, -1, -1):
        at = successor_log_values(mv, logZ[t + 1], cell_ok, norm)
        if keep:
            successors[t] = at
        q = by_owner(mv, move_reward + at)
        logZ[t] = np.where(cell_ok, logsumexp(q, axis=1) - log0(np.maximum(n_ok, 1)), -np.inf)
    return logZ


def _terminal(model, ok, weights):
    """log Z_T per cell: log of the mean of exp(w/tau) over the cell's allowed points."""
    w = np.where(ok, terminal_rewards(model, weights), -np.inf)
    return np.where(ok.any(axis=1), logsumexp(w, axis=1) - log0(np.maximum(ok.sum(axis=1), 1)), -np.inf)


def _lambda_ratio(moves, cell_ok, cell_ok_plus):
    """Lambda_C(m) / Lambda_+(m, k) (P, K): the share of a successor's interpolation weight on vertices
    allowed under C over that under C+ (1 with one entry per move)."""
    w = np.exp(moves.log_weight)
    base = (w * cell_ok[moves.target]).sum(axis=1)
    plus = (w[:, :, None] * cell_ok_plus[moves.target]).sum(axis=1)
    return ratio(base[:, None], plus)


def _candidate_terms(model, moves, regions, candidates):
    """(cell_ok under C (X,), Phi_{C+} times Lambda_C / Lambda_+ per move and candidate (P, K))."""
    ok = points_allowed(model, regions)
    cell_ok = ok.any(axis=1)
    pts = model.points.reshape(-1, model.points.shape[2])
    extra = np.stack([~blocked(c, moves.point, moves.successor) for c in candidates], axis=1).astype(float)
    if moves.target.shape[1] > 1:
        cell_ok_plus = np.stack([(ok & ~c.inside(pts).reshape(ok.shape)).any(axis=1) for c in candidates], axis=1)
        extra *= _lambda_ratio(moves, cell_ok, cell_ok_plus)
    return cell_ok, extra


def satisfaction(model, logZ, regions, candidates, weights, times):
    """F_{C+,t} = Z_{C+,t} / Z_{C,t} (X, K) on the cells at each of ``times`` (a dict t -> array), for the
    ``candidates`` (K regions, each added to ``regions`` = C whose log Z is ``logZ``), by the ratio backup
    F_t(x) = (n_C / n_+) sum over x's allowed moves of pi_C(move) Phi_{C+} (Lambda_C / Lambda_+)
    sum_vertices share F_{t+1}(vertex) (module docstring; n: allowed points of x; 0 where Z_C = 0)."""
    mv = model.moves
    ok = points_allowed(model, regions)
    pts = model.points.reshape(-1, model.points.shape[2])
    ok_plus = np.stack([ok & ~c.inside(pts).reshape(ok.shape) for c in candidates], axis=2)    # (X, M, K)
    n_ratio = ratio(ok.sum(axis=1)[:, None].astype(float), ok_plus.sum(axis=1).astype(float))   # (X, K)
    cell_ok, extra = _candidate_terms(model, mv, regions, candidates)
    w = np.where(ok, terminal_rewards(model, weights), -np.inf)
    with np.errstate(invalid="ignore"):
        share = np.exp(w - logZ[-1][:, None] - log0(ok.sum(axis=1))[:, None])
    share[~np.isfinite(share)] = 0.0
    F = np.einsum("xm,xmk->xk", share, ok_plus) * n_ratio
    out = {model.horizon: F} if model.horizon in times else {}
    move_reward = np.where(allowed_moves(regions, mv), move_rewards(mv, weights), -np.inf)
    norm = successor_norm(mv, cell_ok)
    for t in range(model.horizon - 1, -1, -1):
        at = successor_log_values(mv, logZ[t + 1], cell_ok, norm)
        q = move_reward + at
        p = probabilities(by_owner(mv, q), logZ[t] + log0(ok.sum(axis=1)))
        F = _weighted_sums(mv, p, extra, logZ[t + 1], at, norm, F) * n_ratio
        if t in times:
            out[t] = F
    return out


def vertex_shares(log_weight, target, logZ_next, at, norm):
    """Each vertex's share of its successor's Z (P, k): lambda Z(vertex) / sum over the allowed vertices of
    lambda Z, summing to 1 over a successor's vertices. ``at`` (:func:`successor_log_values`) includes the
    interpolation's renormalisation ``norm`` (:func:`successor_norm`); the shares must not (0 where the
    successor has no allowed vertex)."""
    with np.errstate(invalid="ignore"):
        return probabilities(log_weight + logZ_next[target], at - norm)


def _weighted_sums(mv, p, extra, logZ_next, at, norm, F_next):
    """sum over each owner's moves of p * extra * F at the successor, F at a successor Z_C-weighted over its
    vertices (:func:`vertex_shares`); ``extra`` carries Lambda_C / Lambda_+."""
    if mv.target.shape[1] == 1:
        at_successor = np.take(F_next, mv.target[:, 0], axis=0)
    else:
        share = vertex_shares(mv.log_weight, mv.target, logZ_next, at, norm)
        targets = mv.by_vertex[0]
        at_successor = share[:, 0, None] * F_next[targets[0]]     # vertex by vertex: no (P, k, K) array
        for j in range(1, len(targets)):
            at_successor += share[:, j, None] * F_next[targets[j]]
    at_successor *= extra
    return np.einsum("of,ofc->oc", p, by_owner(mv, at_successor))


def point_log_values(moves, logZ_next, allowed, cell_ok, weights):
    """log Z_t at continuous points, one exact step ahead of the grid's log Z_{t+1} (``logZ_next`` (X,)):
    log sum_a Phi exp(r dt/tau) Z_{t+1}(f(s, a)) (N,) for the points of ``moves`` (:func:`point_moves`)."""
    q = np.where(allowed, move_rewards(moves, weights), -np.inf) + successor_log_values(moves, logZ_next, cell_ok)
    return logsumexp(by_owner(moves, q), axis=1)


def point_ratios(model, moves, logZ_next, F_next, regions, candidates, weights):
    """F_t = Z_{C+,t} / Z_{C,t} at continuous points (N, K), one exact step ahead of the grid's log Z_{C,t+1}
    and F_{t+1} (X, K): E_{a ~ pi_C}[Phi_{C+} F(f(s, a))] (module docstring)."""
    cell_ok, extra = _candidate_terms(model, moves, regions, candidates)
    norm = successor_norm(moves, cell_ok)
    at = successor_log_values(moves, logZ_next, cell_ok, norm)
    q = by_owner(moves, np.where(allowed_moves(regions, moves), move_rewards(moves, weights), -np.inf) + at)
    p = probabilities(q, logsumexp(q, axis=1))
    return _weighted_sums(moves, p, extra, logZ_next, at, norm, F_next)
