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

with Phi_C(s, a) = 1 when neither s, f(s, a) nor the segment between them enters a forbidden region
(eq. 3.1 with psi = 0: on a deterministic transition the chance of entering is 0 or 1, and eq. 3.3 on the
continuous demonstrations gives exactly psi* = 0). The policy is pi(a | s) = Phi exp(r) Z_{t+1}(f(s, a)) /
Z_t(s) (eq. 2.19), so the log-likelihood of a demonstration telescopes to R(xi)/tau + log Z_L(s_L) -
log Z_0(s_0) when it satisfies C (-inf otherwise), and a tightening C -> C+ that the demonstrations
satisfy gains exactly -log F_0(s_0) + log F_L(s_L) with F = Z_{C+}/Z_C (eq. 2.25 is exact for
deterministic dynamics; F_L = 1 when the demonstration spans the horizon).

**On the grid** Z_t is represented by averages over the *allowed* points of each cell: with the
"sample" scheme the mean over the cell's ``samples`` points s_k outside every region of
sum_a Phi exp(r(s_k, a)) Z_{t+1}(f(s_k, a)); with "barycentric" the cell centre, Z_{t+1} interpolated
linearly at f(centre, a) over the Kuhn simplex's allowed vertices (weights renormalized). Z jumps to 0 at a
region's boundary; a plain cell average would mix the 0 of the points inside into the value of a
successor that lies outside, and so charge every path that passes within a cell of a region for it --
every candidate here touches the demonstrations, so that charge would inflate every gain. Both schemes
are linear in Z; :func:`log_partition` runs in log space, :func:`satisfaction` carries the ratio
F = Z_{C+}/Z_C (Theorem 2.3.1's F with deterministic successors: F_t = E_{a ~ pi_C}[Phi_{C+} F_{t+1}(f(s, a))]).
At continuous points (the demonstrations' starts and ends) the values are one exact step ahead of the grid.
"""

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .discretization import kuhn_weights

SEGMENT_POINTS = 3      # interior points at which a move's straight segment is checked against obstacles


@dataclass(frozen=True, eq=False)
class Moves:
    """One step of ``dt`` from points under every control: ``owner`` (P,) the cell (or point) each move
    starts from, ``point`` and ``successor`` (P, d), ``reward`` (P,) r(point, u) dt (not tempered), and the
    successor on the grid as entries: ``move`` (E,) their move, ``target`` (E,) a cell, ``log_weight`` (E,)
    (the sample's share log(1/M), or the log barycentric weight)."""

    owner: np.ndarray
    point: np.ndarray
    successor: np.ndarray
    reward: np.ndarray
    move: np.ndarray
    target: np.ndarray
    log_weight: np.ndarray

    @property
    def n_moves(self):
        return self.owner.size

    @property
    def one_entry(self):
        """Each move's successor is one cell (the sample scheme): no interpolation to sum."""
        return self.move.size == self.owner.size


@dataclass(frozen=True, eq=False)
class PointModel:
    """The grid's cells as points: ``moves`` of every cell (ordered by cell), ``points`` (X, M, d) the
    points a cell stands for and ``terminal`` (X, M) w at them (not tempered), and ``starts`` where each
    cell's entries begin (for the sums over a cell)."""

    problem: object
    moves: Moves
    points: np.ndarray
    terminal: np.ndarray
    starts: np.ndarray

    @property
    def horizon(self):
        return int(self.problem.horizon)


def _entries(problem, owner, point, successor):
    """Moves from (point -> successor) with their successors on the grid (module docstring)."""
    g = problem.grid
    reward = problem.reward.rate(g, point, _controls_of(problem, owner.size)) * problem.dt
    if problem.scheme == "barycentric":
        vertices, weights = kuhn_weights(g, successor)
        keep = weights > 0
        move = np.broadcast_to(np.arange(owner.size)[:, None], weights.shape)[keep]
        return Moves(owner, point, successor, reward, move, vertices[keep], np.log(weights[keep]))
    return Moves(owner, point, successor, reward, np.arange(owner.size), g.cell_of(successor), np.zeros(owner.size))


def _controls_of(problem, n_moves):
    """The control of each of ``n_moves`` moves laid out as (owner, control, sample) with controls varying."""
    A = problem.n_actions
    reps = n_moves // A
    return np.broadcast_to(problem.controls[None], (reps, A, problem.controls.shape[1])).reshape(-1, problem.controls.shape[1])


def point_model(problem, progress=None):
    """The :class:`PointModel` of ``problem`` (module docstring): the sample scheme draws ``samples``
    points per cell (seeded by ``problem.seed``); barycentric uses the centres. ``progress(done, total)``
    is called as blocks of cells are integrated."""
    g, A = problem.grid, problem.n_actions
    M = problem.samples if problem.scheme == "sample" else 1
    rng = np.random.default_rng([problem.seed, 7])
    if problem.scheme == "sample":
        low, width = g.cell_boxes(np.arange(g.n_cells))
        points = low[:, None, :] + rng.random((g.n_cells, M, g.ndim)) * width[:, None, :]
    else:
        points = g.centers()[:, None, :]
    parts, block = [], max(1, 2 ** 18 // (A * M))
    for start in range(0, g.n_cells, block):
        cells = np.arange(start, min(start + block, g.n_cells))
        # moves ordered (cell, sample, control): the control varies fastest
        x = np.repeat(points[cells].reshape(-1, g.ndim), A, axis=0)
        owner = np.repeat(cells, M * A)
        successor = problem.step(x, np.tile(problem.controls, (cells.size * M, 1)))
        parts.append(_entries(problem, owner, x, successor))
        if progress is not None:
            progress(int(cells[-1]) + 1, g.n_cells)
    moves = _concat(parts)
    row = moves.owner[moves.move]
    starts = np.searchsorted(row, np.arange(g.n_cells))
    terminal = problem.reward.terminal(g, points.reshape(-1, g.ndim)).reshape(g.n_cells, M)
    return PointModel(problem, moves, points, terminal, starts)


def _concat(parts):
    offsets = np.cumsum([0] + [p.n_moves for p in parts[:-1]])
    return Moves(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("owner", "point", "successor", "reward")),
                 np.concatenate([p.move + o for p, o in zip(parts, offsets)]),
                 np.concatenate([p.target for p in parts]), np.concatenate([p.log_weight for p in parts]))


def point_moves(problem, points):
    """:class:`Moves` from continuous ``points`` (N, d) under every control (owner: the point's number)."""
    g, A = problem.grid, problem.n_actions
    points = g.wrap(np.atleast_2d(np.asarray(points, dtype=float)))
    x = np.repeat(points, A, axis=0)
    successor = problem.step(x, np.tile(problem.controls, (len(points), 1)))
    return _entries(problem, np.repeat(np.arange(len(points)), A), x, successor)


def allowed_moves(regions, moves):
    """Phi_C per move (P,): the move's point, its successor and its segment lie outside every region."""
    ok = np.ones(moves.n_moves, dtype=bool)
    for region in regions:
        ok &= ~blocked(region, moves.point, moves.successor)
    return ok


def blocked(region, p, q):
    """Whether the moves p -> q (N, d) enter ``region``: at either end, or (obstacles) on the segment."""
    hit = region.inside(p) | region.inside(q)
    if getattr(region, "kind", "") in ("disk", "box"):
        for k in range(1, SEGMENT_POINTS + 1):
            s = k / (SEGMENT_POINTS + 1)
            hit |= region.inside(p + s * (q - p))
    return hit


def _segment_logsumexp(v, starts):
    """log sum exp of v (E, ...) over the segments beginning at ``starts`` (-inf for empty sums)."""
    m = np.maximum.reduceat(v, starts, axis=0)
    shift = np.where(np.isfinite(m), m, 0.0)
    counts = np.diff(np.r_[starts, v.shape[0]])
    with np.errstate(divide="ignore"):
        return np.log(np.add.reduceat(np.exp(v - np.repeat(shift, counts, axis=0)), starts, axis=0)) + shift


def _log(x):
    with np.errstate(divide="ignore"):
        return np.log(x)


def points_allowed(model, regions):
    """(X, M) booleans: the cells' points that lie outside every region."""
    pts = model.points.reshape(-1, model.points.shape[2])
    ok = np.ones(len(pts), dtype=bool)
    for region in regions:
        ok &= ~region.inside(pts)
    return ok.reshape(model.points.shape[:2])


def _entry_starts(moves):
    return np.searchsorted(moves.move, np.arange(moves.n_moves))


def _owner_starts(moves):
    return np.searchsorted(moves.owner, np.arange(moves.owner.max() + 1))


def successor_log_values(moves, logZ_next, cell_ok):
    """log Z_{t+1} at every move's successor (P,): its cell's value (sample scheme), or the interpolation
    over the allowed vertices with their weights renormalized (barycentric); ``cell_ok`` (X,): cells with
    an allowed point."""
    if moves.one_entry:
        return logZ_next[moves.target]
    starts = _entry_starts(moves)
    value = _segment_logsumexp(moves.log_weight + logZ_next[moves.target], starts)
    mass = np.add.reduceat(np.exp(moves.log_weight) * cell_ok[moves.target], starts)
    return np.where(mass > 0, value - _log(np.maximum(mass, 1e-300)), -np.inf)


def log_partition(model, regions=(), temperature=1.0):
    """log Z_{C,t} (T+1, X) on the cells for the constraint set ``regions`` (module docstring)."""
    mv = model.moves
    ok = points_allowed(model, regions)
    n_ok, cell_ok = ok.sum(axis=1), ok.any(axis=1)
    move_reward = np.where(allowed_moves(regions, mv), mv.reward / temperature, -np.inf)
    logZ = np.empty((model.horizon + 1, ok.shape[0]))
    logZ[-1] = _terminal(model, ok, temperature)
    owners = _owner_starts(mv)
    for t in range(model.horizon - 1, -1, -1):
        q = move_reward + successor_log_values(mv, logZ[t + 1], cell_ok)
        logZ[t] = np.where(cell_ok, _segment_logsumexp(q, owners) - _log(np.maximum(n_ok, 1)), -np.inf)
    return logZ


def _terminal(model, ok, temperature):
    """log Z_T per cell: log of the mean of exp(w/tau) over the cell's allowed points."""
    w = np.where(ok, model.terminal / temperature, -np.inf)
    m = w.max(axis=1)
    shift = np.where(np.isfinite(m), m, 0.0)
    return np.where(ok.any(axis=1), _log(np.exp(w - shift[:, None]).sum(axis=1)) + shift
                    - _log(np.maximum(ok.sum(axis=1), 1)), -np.inf)


def _lambda_ratio(moves, cell_ok, cell_ok_plus):
    """Lambda_C(m) / Lambda_+(m, k) (P, K): 1 for the sample scheme (one entry per move)."""
    starts = _entry_starts(moves)
    w = np.exp(moves.log_weight)
    base = np.add.reduceat(w * cell_ok[moves.target], starts)
    plus = np.add.reduceat(w[:, None] * cell_ok_plus[moves.target], starts, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = base[:, None] / plus
    r[~np.isfinite(r)] = 0.0
    return r


def satisfaction(model, logZ, regions, candidates, temperature, times):
    """F_{C+,t} = Z_{C+,t} / Z_{C,t} (X, K) on the cells at each of ``times`` (a dict t -> array), for the
    ``candidates`` (K regions, each added to ``regions`` = C whose log Z is ``logZ``), by the ratio backup
    F_t(x) = (n_C / n_+) sum over x's allowed moves of pi_C(move) Phi_{C+} (Lambda_C / Lambda_+)
    sum_entries share F_{t+1}(vertex) (module docstring; n: allowed points of x; 0 where Z_C = 0)."""
    mv = model.moves
    ok = points_allowed(model, regions)
    ok_plus = np.stack([ok & ~c.inside(model.points.reshape(-1, model.points.shape[2])).reshape(ok.shape)
                        for c in candidates], axis=2)                                            # (X, M, K)
    n_ratio = _ratio(ok.sum(axis=1)[:, None], ok_plus.sum(axis=1))                              # (X, K)
    cell_ok, cell_ok_plus = ok.any(axis=1), ok_plus.any(axis=1)
    extra = np.stack([~blocked(c, mv.point, mv.successor) for c in candidates], axis=1).astype(float)   # (P, K)
    if not mv.one_entry:
        extra = extra * _lambda_ratio(mv, cell_ok, cell_ok_plus)
    w = np.where(ok, model.terminal / temperature, -np.inf)
    with np.errstate(invalid="ignore"):
        share = np.exp(w - logZ[-1][:, None] - _log(ok.sum(axis=1))[:, None])
    share[~np.isfinite(share)] = 0.0
    F = np.einsum("xm,xmk->xk", share, ok_plus) * n_ratio
    out = {model.horizon: F} if model.horizon in times else {}
    move_reward = np.where(allowed_moves(regions, mv), mv.reward / temperature, -np.inf)
    owners, starts = _owner_starts(mv), _entry_starts(mv)
    for t in range(model.horizon - 1, -1, -1):
        at = successor_log_values(mv, logZ[t + 1], cell_ok)
        p_move = _probabilities(move_reward + at, owners, mv.owner, logZ[t] + _log(ok.sum(axis=1)))
        F = _weighted_sums(mv, p_move, extra, _shares(mv, logZ[t + 1], at, starts), F, starts, owners) * n_ratio
        if t in times:
            out[t] = F
    return out


def _ratio(a, b):
    with np.errstate(divide="ignore", invalid="ignore"):
        r = a / b
    r[~np.isfinite(r)] = 0.0
    return r


def _probabilities(q, owners, owner, total):
    """exp(q - total[owner]) with 0 where undefined: each move's probability within its cell or point."""
    with np.errstate(invalid="ignore"):
        p = np.exp(q - total[owner])
    p[~np.isfinite(p)] = 0.0
    return p


def _shares(moves, logZ_next, at, starts):
    """Each entry's share of its move's successor value: lambda Z(vertex) / sum lambda Z (E,)."""
    if moves.one_entry:
        return None
    with np.errstate(invalid="ignore"):
        share = np.exp(moves.log_weight + logZ_next[moves.target] - at[moves.move])
    share[~np.isfinite(share)] = 0.0
    return share


def _weighted_sums(mv, p_move, extra, share, F_next, starts, owners):
    """sum over each owner's moves of p * extra * (sum over the move's entries of share * F_next[target]),
    as one sparse (owners x moves) product per step; ``extra`` (P, K) floats."""
    if share is None:
        at_successor = np.take(F_next, mv.target, axis=0)
    else:
        per_entry = np.take(F_next, mv.target, axis=0)
        per_entry *= share[:, None]
        at_successor = np.add.reduceat(per_entry, starts, axis=0)
    at_successor *= extra
    indptr = np.r_[owners, mv.n_moves]
    A = sp.csr_matrix((p_move, np.arange(mv.n_moves), indptr), shape=(owners.size, mv.n_moves))
    return A @ at_successor


def point_log_values(moves, logZ_next, allowed, cell_ok, temperature):
    """log Z_t at continuous points, one exact step ahead of the grid's log Z_{t+1} (``logZ_next`` (X,)):
    log sum_a Phi exp(r dt/tau) Z_{t+1}(f(s, a)) (N,) for the points of ``moves`` (:func:`point_moves`)."""
    q = np.where(allowed, moves.reward / temperature, -np.inf) + successor_log_values(moves, logZ_next, cell_ok)
    return _segment_logsumexp(q, _owner_starts(moves))


def point_ratios(model, moves, logZ_next, F_next, regions, candidates, temperature):
    """F_t = Z_{C+,t} / Z_{C,t} at continuous points (N, K), one exact step ahead of the grid's log Z_{C,t+1}
    and F_{t+1} (X, K): E_{a ~ pi_C}[Phi_{C+} F(f(s, a))] (module docstring)."""
    ok = points_allowed(model, regions)
    cell_ok = ok.any(axis=1)
    pts = model.points.reshape(-1, model.points.shape[2])
    cell_ok_plus = np.stack([(ok & ~c.inside(pts).reshape(ok.shape)).any(axis=1) for c in candidates], axis=1)
    extra = np.stack([~blocked(c, moves.point, moves.successor) for c in candidates], axis=1).astype(float)
    if not moves.one_entry:
        extra = extra * _lambda_ratio(moves, cell_ok, cell_ok_plus)
    starts, owners = _entry_starts(moves), _owner_starts(moves)
    at = successor_log_values(moves, logZ_next, cell_ok)
    q = np.where(allowed_moves(regions, moves), moves.reward / temperature, -np.inf) + at
    p = _probabilities(q, owners, moves.owner, _segment_logsumexp(q, owners))
    return _weighted_sums(moves, p, extra, _shares(moves, logZ_next, at, starts), F_next, starts, owners)
