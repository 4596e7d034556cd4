"""The constraint backups of Chapter 2 (Algorithms 1-4), vectorized over candidates.

Every algorithm takes K candidate constraint sets at once as an allowed-action
mask of shape (X, A, K) and is vectorized over states, actions and candidates;
only time (and, to bound memory, blocks of candidates) is looped over.

* :func:`expected_features` -- Algorithm 1 (Ziebart's forward-backward pass).
* :func:`constraint_accrual` -- Algorithm 2 (Scobee and Sastry's forward accrual;
  exact for deterministic dynamics only).
* :func:`value_ratio` -- Algorithm 3 (Theorem 2.3.1: log F_{C+} by a modified backup).
* :func:`log_partition` -- Algorithm 4 (the pure soft backup: log Z_{C+} = V_{C+,0}).
* :func:`rank_candidates` -- log F and the exact likelihood gain of every candidate.

Algorithm 4 runs on one of three engines: ``"jax"``, the compiled stencil backup of
:mod:`.fast` (grids: successors at a few fixed index offsets), ``"gather"``, the compiled backup
of :mod:`.gather` for any MDP with at most ``gather.MAX_SUCCESSORS`` successors per state-action
pair (the discretized continuous systems of :mod:`.continuous`), or ``"numpy"``, a log-space
backup with a (sparse) matrix product per step that takes any MDP. ``engine="auto"`` (the
default) uses jax where it applies, else numpy; the tests check that all three give the same
numbers. :func:`rank_candidates` backs up only the states that the demonstrations' starts can
reach within the horizon (:mod:`.reachable`; the same numbers) where the stencil does not apply.
"""

import numpy as np
import scipy.sparse as sp

from . import fast, gather
from .demonstrations import check_demonstrations
from . import mdp as _mdp
from .mdp import check_mask, expected_next, masked_logsumexp, soft_bellman_backup, soft_policy
from .reachable import restricted


_BLOCK_ENTRIES = 2 ** 22  # bound on X * A * (candidates per block): 32 MiB of float64
ENGINES = ("auto", "jax", "numpy", "gather")


def _masks(mdp, masks):
    masks = check_mask(mdp, masks, "masks")
    return masks[:, :, None] if masks.ndim == 2 else masks


def _blocks(mdp, n):
    size = max(1, _BLOCK_ENTRIES // (mdp.n_states * mdp.n_actions))
    return [slice(i, min(i + size, n)) for i in range(0, n, size)]


def log_partition(mdp, masks, engine="auto"):
    """Algorithm 4: log Z_{C,0}(x) = V^soft_{C,0}(x) for every candidate mask (eq. 2.24).

    ``masks``: Phi_C as (X, A) or (X, A, K). Returns (X, K) (K = 1 for one mask).
    The backup runs in log space, so long horizons and large rewards are safe.
    ``engine``: "auto", "jax" (compiled, grids only), "gather" (compiled, few successors per
    state-action pair) or "numpy" (module docstring).
    """
    return _batched_backup(mdp, _masks(mdp, masks), engine=engine)[0]


def _engine_form(mdp, engine):
    """The stencil form for the compiled engine, or None for the numpy one."""
    if engine not in ENGINES:
        raise ValueError(f"engine: must be one of {ENGINES}, got {engine!r}")
    if engine == "gather":
        form = gather.gather_form(mdp)
        if form is None:
            raise ValueError(f"engine: the gather backup needs <= {gather.MAX_SUCCESSORS} successors per state-action "
                             "pair, transition probabilities >= 1e-140 and jax installed; use engine='numpy'")
        return form
    form = None if engine == "numpy" else fast.stencil_form(mdp)
    if engine == "jax" and form is None:
        raise ValueError("engine: the compiled backup needs successors at <= 27 fixed index offsets, "
                         "transition probabilities >= 1e-140 and jax installed; use engine='numpy'")
    return form


def backup_columns(mdp, masks_of, n, demos=None, engine="auto", layers=None):
    """Algorithm 4 for ``n`` candidates whose masks Phi_C (X, A, k) ``masks_of(block)`` returns
    for a slice of them, block by block so memory stays bounded: ``(V0 (X, n), log_lik (n,))``,
    the log-likelihood of ``demos`` under each (eq. 2.19; -inf where infeasible, 0 without demos).
    ``layers``: the gather engine may compute V_t on the first ``layers[t]`` states only
    (:func:`.gather.segments`; V0 is then right on the first ``layers[0]``)."""
    form = _engine_form(mdp, engine)
    allowed = lambda b: masks_of(b) & mdp.allowed[:, :, None]      # noqa: E731
    if isinstance(form, gather.GatherForm):
        return gather.backup_blocks(mdp, form, allowed, n, demos, layers)
    if form is not None:
        return fast.backup_blocks(mdp, form, allowed, n, demos)
    V0, log_lik = np.empty((mdp.n_states, n)), np.empty(n)
    for block in _blocks(mdp, n):
        V0[:, block], log_lik[block] = _numpy_backup(mdp, masks_of(block) & mdp.allowed[:, :, None], demos)
    return V0, log_lik


def log_partition_literal(mdp, masks):
    """Algorithm 4 transcribed line by line (linear space, loops over t, x, a, x').

    The reference the vectorized :func:`log_partition` is tested and benchmarked
    against; far too slow for real use (``O(T |X|^2 |A|)`` Python steps).
    """
    masks = _masks(mdp, masks)
    S, K = mdp.dense_transitions(), masks.shape[2]
    Z = np.exp(mdp.terminal_reward)[:, None] * np.ones(K)
    for _ in range(mdp.horizon):
        Z_new = np.zeros_like(Z)
        for x in range(mdp.n_states):
            for a in range(mdp.n_actions):
                Q = mdp.reward[x, a] * np.ones(K)
                for x2 in range(mdp.n_states):
                    if S[x, a, x2] > 0:     # 0 log 0 = 0: an unreachable x' adds nothing
                        Q += S[x, a, x2] * np.log(Z[x2])
                Z_new[x] += masks[x, a] * np.exp(Q)
        Z = Z_new
    return np.log(Z)


def _batched_backup(mdp, masks, demos=None, engine="auto"):
    """Algorithm 4 for the (X, A, K) ``masks`` (see :func:`backup_columns`)."""
    return backup_columns(mdp, lambda block: masks[:, :, block], masks.shape[2], demos, engine)


def _expected_next(mdp, V):
    """:func:`expected_next` with one product with S per step: -inf is carried as the finite
    ``fast.LOW`` (exact when every positive S >= fast.MIN_PROBABILITY; see :mod:`.fast`)."""
    if not fast.sentinel_is_exact(mdp):
        return expected_next(mdp, V)
    Q = _mdp._times_transitions(mdp, np.maximum(V, fast.LOW)).reshape((mdp.n_states, mdp.n_actions) + V.shape[1:])
    Q[Q < fast.DEAD] = -np.inf
    return Q


def _numpy_backup(mdp, masks, demos=None):
    """Algorithm 4 in numpy for one block of masks; with ``demos`` also each candidate's
    demonstration log-likelihood sum_i sum_t log P_C(a_t | x_t, t) (eq. 2.19), gathered
    from the same pass (-inf where a demonstration is infeasible)."""
    forbidden = ~masks
    log_lik = np.zeros(masks.shape[2])
    V = np.repeat(mdp.terminal_reward[:, None], forbidden.shape[2], axis=1)
    for t in range(mdp.horizon - 1, -1, -1):
        Q = _expected_next(mdp, V)
        Q += mdp.reward[:, :, None]
        if demos is not None and t < demos.steps:
            x, a = demos.states[:, t], demos.actions[:, t]
            q = np.where(forbidden[x, a], -np.inf, Q[x, a])
        V = masked_logsumexp(Q, forbidden)
        if demos is not None and t < demos.steps:
            with np.errstate(invalid="ignore"):
                step = (q - V[x]).sum(axis=0)
            log_lik += np.where(np.isnan(step), -np.inf, step)
    return V, log_lik


def value_ratio(mdp, base_mask, masks):
    """Algorithm 3 (Theorem 2.3.1, eq. 2.26): log F_{C+,0}(x) = log(Z_{C+} / Z_{C0}) for each
    candidate mask, by the modified backup F_t = E_{a ~ P_C0}[Phi_{C+} exp(E_{x'} log F_{t+1})].

    ``base_mask``: Phi_{C0} (X, A); ``masks``: Phi_{C+} (X, A, K). Returns log F as (X, K),
    -inf where C0 itself allows no trajectory. Computed in log space alongside the
    baseline backup (one backward pass).
    """
    base = check_mask(mdp, base_mask, "base_mask")
    masks = _masks(mdp, masks)
    if base.ndim != 2:
        raise ValueError("base_mask: must be one (X, A) mask")
    _, Q0 = soft_bellman_backup(mdp, base)
    out = np.empty((mdp.n_states, masks.shape[2]))
    for block in _blocks(mdp, masks.shape[2]):
        forbidden = ~masks[:, :, block]
        log_f = np.zeros((mdp.n_states, forbidden.shape[2]))
        for t in range(mdp.horizon - 1, -1, -1):
            log_pi = _log_policy(Q0[t])
            D = _expected_next(mdp, log_f)
            D += log_pi[:, :, None]
            log_f = masked_logsumexp(D, forbidden)
        out[:, block] = log_f
    return out


def _log_policy(Q):
    """log P_C0(a | x) = Q - V (eq. 2.19), -inf for forbidden actions and dead states."""
    V = masked_logsumexp(Q.copy(), None)
    with np.errstate(invalid="ignore"):
        log_pi = Q - V[:, None]
    log_pi[np.isnan(log_pi)] = -np.inf
    return log_pi


def constraint_accrual(mdp, base_mask, masks):
    """Algorithm 2 (Scobee and Sastry): P_{C0}(xi satisfies C+) for each candidate, by
    forward-simulating the C0 policy from ``mdp.initial`` and accruing the mass that
    first violates C+. Returns (K,). Equals Z_{C+}/Z_{C0} only for deterministic dynamics.
    """
    pi = soft_policy(mdp, check_mask(mdp, base_mask, "base_mask"))
    masks = _masks(mdp, masks)
    out = np.empty(masks.shape[2])
    for block in _blocks(mdp, masks.shape[2]):
        violates = ~masks[:, :, block]
        D = mdp.initial.copy()
        H = np.zeros((mdp.n_states, violates.shape[2]))
        for t in range(mdp.horizon):
            # lines 24 and 33: H(t+1) = sum_{x,a} (H + phi (D - H)) P(a|x) S(x, a, .)
            W = np.where(violates, D[:, None, None], H[:, None, :])
            W *= pi[t][:, :, None]
            H = _mdp._transpose_times(mdp, W.reshape(-1, W.shape[2]))
            D = _mdp._transpose_times(mdp, (D[:, None] * pi[t]).ravel())
        out[block] = 1.0 - H.sum(axis=0)
    return out


def algorithm_agreement(mdp, demos, candidates, base_mask=None):
    """Compare Algorithms 2, 3 and 4 on every candidate (Theorem 2.3.1, eq. 2.25).

    Returns ``alg34`` (max |F_3 - exp(V_C+ - V_C0)| over candidates and states where C0 is
    feasible), ``alg23`` (max |F_2 - F_3(start)|, with ``mdp.initial`` a point mass),
    ``same_ranking`` (Algorithms 3 and 4 order the candidates identically), arrays
    ``F2``, ``F3`` (K,) and, for the feasible candidates, ``log_f`` and exact ``gain``
    from :func:`rank_candidates`.
    """
    base = check_mask(mdp, base_mask, "base_mask")
    masks = base[:, :, None] & ~candidates.forbidden
    V0, V = log_partition(mdp, base)[:, 0], log_partition(mdp, masks)
    log_f3 = value_ratio(mdp, base, masks)
    finite = np.isfinite(V)
    start = int(np.argmax(mdp.initial))
    F2, F3 = constraint_accrual(mdp, base, masks), np.exp(log_f3[start])
    log_f, gain = rank_candidates(mdp, demos, candidates.forbidden[:, :, candidates.feasible], base)
    with np.errstate(invalid="ignore"):
        alg34 = np.abs(np.exp(log_f3[finite]) - np.exp((V - V0[:, None])[finite]))
    return dict(alg34=float(alg34.max()), alg23=float(np.max(np.abs(F2 - F3))), F2=F2, F3=F3, log_f=log_f, gain=gain,
                same_ranking=bool(np.array_equal(np.argsort(log_f3[start], kind="stable"),
                                                 np.argsort(V[start] - V0[start], kind="stable"))))


def state_action_visitation(mdp, mask=None):
    """Expected visitation D(t, x) P_C(a | x, t) of every (t, x, a), shape (T, X, A),
    from ``mdp.initial`` under the constrained soft policy (Algorithm 1, lines 17-30)."""
    pi = soft_policy(mdp, mask)
    occupancy = np.empty_like(pi)
    D = mdp.initial
    for t in range(mdp.horizon):
        occupancy[t] = D[:, None] * pi[t]
        D = _mdp._transpose_times(mdp, occupancy[t].ravel())
    return occupancy


def expected_features(mdp, features, mask=None):
    """Algorithm 1: expected feature accruals sum_t sum_{x,a} D(t, x) P(a | x, t) phi(x, a).

    ``features``: phi as (X, A, n) or (X, n) (state features). Returns (n,).
    """
    phi = np.asarray(features, dtype=float)
    if phi.ndim == 2 and phi.shape[0] == mdp.n_states:
        phi = np.repeat(phi[:, None, :], mdp.n_actions, axis=1)
    if phi.ndim != 3 or phi.shape[:2] != (mdp.n_states, mdp.n_actions):
        raise ValueError(f"features: shape {phi.shape} should be (X, A, n) or (X, n)")
    return np.einsum("txa,xan->n", state_action_visitation(mdp, mask), phi)


def forbidden_columns(mdp, forbidden, name="forbidden"):
    """``(K, columns)`` for candidate forbidden sets given as a boolean (X, A, K) array or a
    sparse (X*A, K) matrix; ``columns(block)`` returns a dense (X, A, k) boolean block."""
    X, A = mdp.n_states, mdp.n_actions
    if sp.issparse(forbidden):
        if forbidden.ndim != 2 or forbidden.shape[0] != X * A:
            raise ValueError(f"{name}: a sparse forbidden matrix must have shape (X*A, K) with X*A = {X * A}, "
                             f"got {forbidden.shape}")
        csc = sp.csc_matrix(forbidden, dtype=bool)
        return csc.shape[1], lambda block: csc[:, block].toarray().reshape(X, A, -1)
    forbidden = np.asarray(forbidden)
    if forbidden.dtype != bool or forbidden.ndim != 3 or forbidden.shape[:2] != (X, A):
        raise ValueError(f"{name}: must be a boolean array of shape (X, A, K) with (X, A) = {(X, A)}, "
                         f"got dtype {forbidden.dtype} and shape {forbidden.shape}")
    return forbidden.shape[2], lambda block: forbidden[:, :, block]


def rank_candidates(mdp, demos, forbidden, base_mask=None, engine="auto", reachable=True):
    """Score candidates that add ``forbidden`` (X, A, K) to Phi_{C0} = ``base_mask``, by Algorithm 4.

    Returns ``(log_f, gain)``, both (K,): ``log_f`` the mean over demonstrations of
    log F_{C+,0}(x_0) (eq. 2.25; the thesis's ranking, smallest first) and ``gain`` the
    exact per-demonstration log-likelihood gain of C+ over C0. The two agree for
    deterministic dynamics (gain = -log_f); under stochastic dynamics the realised
    transitions add a correction. Candidates that make a demonstration infeasible
    (also through combining with C0) get log_f = nan and gain = -inf. ``forbidden`` may
    also be a sparse (X*A, K) matrix; ``engine`` as in :func:`log_partition`. ``reachable``:
    back up only the states the demonstrations' starts reach (:mod:`.reachable`; the same
    numbers) unless the compiled stencil runs.
    """
    check_demonstrations(mdp, demos)
    base = check_mask(mdp, base_mask, "base_mask")
    if base.ndim != 2:
        raise ValueError("base_mask: must be one (X, A) mask")
    n, columns = forbidden_columns(mdp, forbidden)
    layers = None
    if reachable and not (engine in ("auto", "jax") and _engine_form(mdp, engine) is not None):
        part = restricted(mdp, demos.states[:, 0])
        if part is not None:
            mdp, demos, base, layers = part.mdp, part.demos(demos), part.mask(base), part.layers
            n, columns = forbidden_columns(mdp, part.columns(forbidden))
    starts = demos.states[:, 0]

    def masks_of(block):       # candidate 0 is C0 itself, the baseline, backed up with the rest
        first, stop = max(block.start, 1), block.stop
        head = np.broadcast_to(base[:, :, None], base.shape + (first - block.start,))
        return np.concatenate([head, base[:, :, None] & ~columns(slice(first - 1, stop - 1))], axis=2)

    V, ll = backup_columns(mdp, masks_of, n + 1, demos, engine, layers)
    if not np.isfinite(ll[0]):
        raise ValueError("base_mask: the baseline constraints make a demonstration infeasible")
    V, V0, ll, ll0 = V[:, 1:], V[:, :1], ll[1:], ll[0]
    feasible = np.isfinite(ll)
    with np.errstate(invalid="ignore"):
        log_f = np.where(feasible, (V[starts] - V0[starts]).mean(axis=0), np.nan)
    return log_f, np.where(feasible, (ll - ll0) / demos.n, -np.inf)
