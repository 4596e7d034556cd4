"""A compiled soft backup (Algorithm 4) for MDPs with few successors per state-action pair, in any layout.

A discretized continuous system (:mod:`.continuous`) reaches from each cell a handful of cells (the
d + 1 vertices of a Kuhn simplex), but not at index offsets shared by all cells, so the stencil of
:mod:`.fast` does not apply. Here S is written in *gather form*, index[x, a, j] and P[x, a, j] =
S(x, a, index[x, a, j]) for J slots (padded with P = 0), and E_{x'} V(x') = sum_j P[x, a, j]
V(index[x, a, j]) is a gather per slot that XLA fuses with the reward, the mask Phi_C and the
log-sum-exp over actions (eq. 2.21) into one pass per step, in float64, with -inf carried as
``fast.LOW`` exactly as in :mod:`.fast` (the same numbers as the numpy backup).

* **Slots.** J is what most pairs need (a Kuhn-triangulated system: d + 1). The few pairs with more
  successors (a recorded step that :mod:`.continuous.mapping` added to S) point their last slot at
  an auxiliary row X + r holding sum_{j >= J-1} P_j V(x'_j) of their remaining successors (a small
  table, recomputed each step), so one long row does not make every row pay for its length.
* **Layers.** With the states numbered by the step at which the demonstrations' starts first reach
  them (:mod:`.reachable`), V_{C,t} is needed on the first n_t states only: the scan runs in a few
  segments, each over a prefix of the states (:func:`segments`), and skips the rest.
"""

import weakref
from collections import namedtuple

import numpy as np
import scipy.sparse as sp

from .fast import MIN_PROBABILITY, demo_steps, run_blocks

MAX_SUCCESSORS = 64       # at most this many successors per state-action pair
OVERFLOW_SHARE = 1 / 256  # the slots hold every successor of all pairs but at most this share of them
MAX_SEGMENTS = 4          # prefix segments of the scan (each is compiled)

_GATHER = weakref.WeakKeyDictionary()
_KERNELS = {}

GatherForm = namedtuple("GatherForm", "index P extra_index extra_P")
GatherForm.__doc__ = ("S in gather form (module docstring): ``index`` (X, A, J) int32 successors (X + r: auxiliary "
                      "row r) and ``P`` (X, A, J) their probabilities; ``extra_index``, ``extra_P`` (R, E) the "
                      "successors that auxiliary row r averages over.")


def gather_form(mdp):
    """:class:`GatherForm` of any MDP whose state-action pairs reach at most ``MAX_SUCCESSORS`` states with
    probabilities >= ``fast.MIN_PROBABILITY``, or None (also without jax). Cached per MDP."""
    if mdp in _GATHER:
        return _GATHER[mdp]
    try:
        import jax  # noqa: F401
    except ImportError:      # pragma: no cover - jax is in the lock
        jax = None
    csr = sp.csr_matrix(mdp.transitions)
    csr.eliminate_zeros()
    counts = np.diff(csr.indptr)
    most = int(counts.max()) if counts.size else 0
    form = None
    if jax is not None and csr.nnz and 0 < most <= MAX_SUCCESSORS and csr.data.min() >= MIN_PROBABILITY:
        form = _layout(csr, counts, mdp.n_states, mdp.n_actions)
    _GATHER[mdp] = form
    return form


def _layout(csr, counts, X, A):
    longer = counts.size - np.cumsum(np.bincount(counts))             # pairs with more than J successors
    J = int(np.flatnonzero(longer <= OVERFLOW_SHARE * counts.size)[0])
    over = np.flatnonzero(counts > J)
    J = max(J, 2) if over.size else J
    row = np.repeat(np.arange(X * A), counts)
    slot = np.arange(csr.nnz) - np.repeat(csr.indptr[:-1], counts)
    long_row = np.zeros(X * A, dtype=bool)
    long_row[over] = True
    main = (slot < J) & ~(long_row[row] & (slot >= J - 1))
    index, P = np.zeros((X * A, J), dtype=np.int32), np.zeros((X * A, J))
    index[row[main], slot[main]], P[row[main], slot[main]] = csr.indices[main], csr.data[main]
    E = max(1, int(counts.max()) - J + 1)
    extra_index, extra_P = np.zeros((max(1, over.size), E), dtype=np.int32), np.zeros((max(1, over.size), E))
    r = np.searchsorted(over, row[~main])
    extra_index[r, slot[~main] - J + 1], extra_P[r, slot[~main] - J + 1] = csr.indices[~main], csr.data[~main]
    index[over, J - 1], P[over, J - 1] = X + np.arange(over.size), 1.0        # the auxiliary rows
    return GatherForm(index.reshape(X, A, J), P.reshape(X, A, J), extra_index, extra_P)


def block_size(n):
    """Candidates per compiled block: 16 (measured fastest per candidate on the cart-pole), or the
    power of two that holds ``n`` when fewer (a lone baseline gets a block of 1)."""
    return min(16, 1 << (max(n, 1) - 1).bit_length())


def segments(layers, horizon):
    """The scan's segments, last step first: ``((m, steps), ...)``, V computed on the first m states
    for ``steps`` steps. ``layers``: n_t (t = 0..T-1), the prefix of states needed at step t, or None
    (all states, one segment). At most ``MAX_SEGMENTS``, chosen to compute the fewest state-steps."""
    if layers is None:
        return None
    n = np.maximum.accumulate(np.asarray(layers, dtype=np.int64)[:horizon])[::-1]   # step T-1 first
    T = n.size
    cost = {0: (0, ())}                      # steps covered -> (state-steps, plan), with s segments
    best = None
    for _ in range(MAX_SEGMENTS):
        new = {}
        for i, (c, plan) in cost.items():
            for k in range(i + 1, T + 1):    # a segment over steps i..k-1 needs n[i] states
                value = (c + int(n[i]) * (k - i), plan + ((int(n[i]), k - i),))
                if k not in new or value[0] < new[k][0]:
                    new[k] = value
        cost = {k: v for k, v in new.items() if k < T}
        if T in new and (best is None or new[T][0] < best[0]):
            best = new[T]
    return best[1]


def _kernel():
    """The jitted backup: ``run(*form, R, w, forbidden, dx, da, valid, plan)``."""
    if "gather" not in _KERNELS:
        import jax
        import jax.numpy as jnp

        from .fast import soft_step

        def run(index, P, extra_index, extra_P, R, w, forbidden, dx, da, valid, plan):
            X, Kb, (R_, E) = P.shape[0], forbidden.shape[2], extra_index.shape

            def refresh(V):
                """V with the auxiliary rows X + r recomputed: sum_e P V(x'_e) over row r's successors."""
                aux = sum(extra_P[:, e, None] * V[extra_index[:, e]] for e in range(E))
                return jax.lax.dynamic_update_slice_in_dim(V, aux, X, axis=0)

            V = jnp.concatenate([jnp.broadcast_to(w[:, None], (X, Kb)), jnp.zeros((R_, Kb))])
            carry, start = (refresh(V), jnp.zeros(Kb), jnp.zeros(Kb, dtype=bool)), 0
            for m, steps in plan or ((X, dx.shape[0]),):
                def expected(V, m=m):
                    return sum(P[:m, :, j, None] * V[index[:m, :, j]] for j in range(P.shape[2]))

                step = soft_step(expected, R[:m], forbidden[:m], refresh=refresh)
                carry, _ = jax.lax.scan(step, carry, (dx[start:start + steps], da[start:start + steps],
                                                      valid[start:start + steps]))
                start += steps
            V, ll, infeasible = carry
            return V[:X], ll, infeasible

        _KERNELS["gather"] = jax.jit(run, static_argnames=("plan",))
    return _KERNELS["gather"]


def backup_blocks(mdp, form, masks_of, n, demos=None, layers=None):
    """Algorithm 4 for ``n`` candidate masks on the :class:`GatherForm` ``form``, compiled: ``masks_of(block)``
    gives the allowed masks Phi_C (X, A, k) of the candidates in ``block`` (a slice). Returns ``(V0,
    log_lik)``: V_{C,0} as (X, n) and the demonstrations' log-likelihood (n,), -inf where infeasible.
    ``layers`` (:func:`segments`): V0 is then right on the first ``layers[0]`` states only."""
    import jax
    import jax.numpy as jnp

    plan = segments(layers, mdp.horizon)
    with jax.enable_x64(True):
        args = [jnp.asarray(a) for a in (*form, mdp.reward, mdp.terminal_reward)]
        rev = [jnp.asarray(a) for a in demo_steps(mdp, demos)]
        return run_blocks(mdp, masks_of, n, block_size(n),
                          lambda forbidden: _kernel()(*args, jnp.asarray(forbidden), *rev, plan=plan))
