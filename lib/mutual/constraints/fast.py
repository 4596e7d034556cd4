"""A compiled soft backup (Algorithm 4) for MDPs whose successors lie at a few fixed index offsets.

On a grid every state x reaches only x + o_j for a handful of offsets o_j shared by all
states (the gridworld of Section 3.3: the eight neighbours and itself, o in {0, +-1, +-W,
+-W +- 1}). Writing S in this *stencil form*, P[x, a, j] = S(x, a, x + o_j), the expectation
of eq. (2.20) is a sum of shifted copies of V,

    E_{x'} V(x') = sum_j P[x, a, j] V(x + o_j),

with no gather and no sparse-matrix indexing, so XLA fuses the whole backup step -- the
products, the reward, the mask Phi_C and the log-sum-exp over actions (eq. 2.21) -- into one
pass over the (X, A, K) block of candidates. The time loop runs as one compiled ``lax.scan``
in float64 (``jax.enable_x64`` as a context: nothing global changes), over blocks of
candidates that bound memory. The same scan gathers each candidate's demonstration
log-likelihood sum_i sum_t log P_C(a_t | x_t, t) (eq. 2.19).

Minus infinity (a state with no allowed action, V = -inf) is carried as the finite
``LOW = -1e300`` so that 0 * V stays 0: any value below ``DEAD = -1e150`` is snapped back to
LOW after each step and reported as -inf. This is exact -- the same -inf pattern and the same
finite values as the log-space numpy backup -- whenever the smallest positive transition
probability exceeds 1e-140 (then p LOW < DEAD - 1e100, while every finite value is bounded by
``mdp.MAX_VALUE`` = 1e100 plus T log |A|). :func:`stencil_form` returns None -- and callers use
the numpy backup -- when that fails, when the successors need more than ``MAX_OFFSETS``
distinct offsets, or when jax is not installed.

Any other layout with few successors per state-action pair (a discretized continuous system)
runs on the gather form of :mod:`.gather`, which shares this module's sentinel and block runner.
"""

import os
import weakref
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.sparse as sp

LOW, DEAD = -1e300, -1e150
MIN_PROBABILITY = 1e-140
MAX_OFFSETS = 27
THREADS = min(2, os.cpu_count() or 1)   # blocks run concurrently (the compendium's machines have 2 cores)
BLOCK_ENTRIES = 2 ** 18   # X * A * (candidates per block): 2 MiB of float64 per (X, A, K) temporary

_FORMS = weakref.WeakKeyDictionary()
_EXACT = weakref.WeakKeyDictionary()
_KERNELS = {}

def stencil_form(mdp):
    """``(offsets, P)`` with P[x, a, j] = S(x, a, x + offsets[j]) (X, A, J), or None when the
    compiled backup does not apply (see the module docstring). Cached per MDP."""
    if mdp in _FORMS:
        return _FORMS[mdp]
    form = None
    try:
        import jax  # noqa: F401
    except ImportError:      # pragma: no cover - jax is in the lock
        jax = None
    coo = sp.coo_matrix(mdp.transitions)
    coo.eliminate_zeros()
    X, A = mdp.n_states, mdp.n_actions
    if jax is not None and coo.nnz and coo.data.min() >= MIN_PROBABILITY:
        x = coo.row // A
        offsets, j = np.unique(coo.col - x, return_inverse=True)
        if offsets.size <= MAX_OFFSETS:
            P = np.zeros((X, A, offsets.size))
            P[x, coo.row % A, j] = coo.data
            form = (tuple(int(o) for o in offsets), P)
    _FORMS[mdp] = form
    return form


def sentinel_is_exact(mdp):
    """Whether -inf may be carried as LOW exactly: every positive S(x, a, x') >= MIN_PROBABILITY."""
    if mdp not in _EXACT:
        data = mdp.transitions.data if mdp.is_sparse else mdp.transitions[mdp.transitions > 0]
        _EXACT[mdp] = bool(data[data > 0].size == 0 or data[data > 0].min() >= MIN_PROBABILITY)
    return _EXACT[mdp]


def block_size(mdp, n):
    """Candidates per compiled block: a power of two from 16 up to the largest that keeps one
    (X, A, block) temporary within BLOCK_ENTRIES (cache-sized; larger blocks measured slower),
    chosen to pad ``n`` candidates least (ties: the larger block). Few distinct shapes get compiled."""
    cap = int(np.clip(np.floor(np.log2(BLOCK_ENTRIES / (mdp.n_states * mdp.n_actions))), 4, 6))
    sizes = [2 ** e for e in range(4, cap + 1)]
    return min(sizes, key=lambda b: (-(-max(n, 1) // b) * b, -b))


def _kernel():
    """The jitted backup scan for S in stencil form."""
    if "stencil" not in _KERNELS:
        import jax
        import jax.numpy as jnp

        def run(P, R, w, forbidden, dx, da, valid, offsets, pad_lo, pad_hi):
            X = P.shape[0]

            def expected(V):
                """E_{x'} V(x') for every (x, a) and candidate: (X, A, Kb)."""
                Vp, EV = jnp.pad(V, ((pad_lo, pad_hi), (0, 0))), 0.0
                for j, o in enumerate(offsets):
                    EV = EV + P[:, :, j, None] * jax.lax.slice_in_dim(Vp, pad_lo + o, pad_lo + o + X)[:, None, :]
                return EV

            step = soft_step(expected, R, forbidden)
            init = (jnp.broadcast_to(w[:, None], (X, forbidden.shape[2])), jnp.zeros(forbidden.shape[2]),
                    jnp.zeros(forbidden.shape[2], dtype=bool))
            return jax.lax.scan(step, init, (dx, da, valid))[0]

        _KERNELS["stencil"] = jax.jit(run, static_argnames=("offsets", "pad_lo", "pad_hi"))
    return _KERNELS["stencil"]


def soft_step(expected, R, forbidden, refresh=None, log=None):
    """One step of the scan (eq. 2.20-2.21) for ``expected(V)`` = E_{x'} V(x') (m, A, Kb) on the first m
    states: V_t = log sum_a Phi_C exp(r + E V_{t+1}) there, and each candidate's demonstration
    log-likelihood sum_i log P_C(a_t | x_t, t) (eq. 2.19) accrued, ``LOW`` for -inf (module docstring).
    The carry holds V for all states; the first m rows are replaced (the rest are never read again),
    then ``refresh(V)``, if given, updates any rows derived from them."""
    import jax
    import jax.numpy as jnp
    log = jnp.log if log is None else log

    def step(carry, inputs):
        V, ll, infeasible = carry
        x_t, a_t, ok = inputs
        Q = jnp.where(forbidden, -jnp.inf, expected(V) + R[:, :, None])
        top = Q.max(axis=1)
        alive = top > DEAD
        shift = jnp.where(alive, top, 0.0)
        Vm = jnp.where(alive, log(jnp.exp(Q - shift[:, None, :]).sum(axis=1)) + shift, LOW)
        V = Vm if Vm.shape == V.shape else jax.lax.dynamic_update_slice_in_dim(V, Vm, 0, axis=0)
        V = V if refresh is None else refresh(V)
        q = Q[x_t, a_t]                                            # (N, Kb)
        lost = q <= DEAD
        ll = ll + jnp.where(ok, jnp.where(lost, 0.0, q - V[x_t]).sum(axis=0), 0.0)
        return (V, ll, infeasible | (ok & lost.any(axis=0))), None

    return step


def demo_steps(mdp, demos):
    """The demonstrations as the scan's inputs, last step first: states, actions (T, N) and which
    steps are demonstrated (T,)."""
    T = mdp.horizon
    steps = 0 if demos is None else demos.steps
    dx = np.zeros((T, 1 if demos is None else demos.n), dtype=np.int32)
    da = np.zeros_like(dx)
    if demos is not None:
        dx[:steps], da[:steps] = demos.states[:, :-1].T, demos.actions.T
    return dx[::-1].copy(), da[::-1].copy(), (np.arange(T) < steps)[::-1].copy()


def run_blocks(mdp, masks_of, n, kb, call):
    """``(V0, log_lik)`` for ``n`` candidates in blocks of ``kb``: ``masks_of(block)`` gives the allowed
    masks (X, A, k) of a slice of them, ``call(forbidden)`` runs a compiled scan on the (X, A, kb)
    forbidden block (padded with the structural mask) and returns its (V, ll, infeasible)."""
    import jax
    X = mdp.n_states
    V0, log_lik = np.empty((X, n)), np.empty(n)

    def one(block):
        masks = masks_of(block)
        pad = kb - masks.shape[2]
        forbidden = np.concatenate([~masks, np.broadcast_to(~mdp.allowed[:, :, None], (X, mdp.n_actions, pad))],
                                   axis=2)
        with jax.enable_x64(True):      # a thread-local setting: each worker enters it
            _collect((block, call(forbidden)), V0, log_lik)

    blocks = [slice(start, min(start + kb, n)) for start in range(0, n, kb)]
    if len(blocks) == 1 or THREADS == 1:
        for block in blocks:
            one(block)
    else:          # XLA releases the GIL while a block runs: one block per core at a time
        with ThreadPoolExecutor(THREADS) as pool:
            list(pool.map(one, blocks))
    return V0, log_lik


def backup_blocks(mdp, form, masks_of, n, demos=None):
    """Algorithm 4 for ``n`` candidate masks, compiled: ``masks_of(block)`` gives the allowed
    masks Phi_C (X, A, k) of the candidates in ``block`` (a slice); ``form`` is the stencil form
    (:func:`stencil_form`). Returns ``(V0, log_lik)``: V_{C,0} as (X, n) and the demonstrations'
    log-likelihood (n,), -inf where infeasible."""
    import jax
    import jax.numpy as jnp

    offsets, P = form
    statics = dict(offsets=offsets, pad_lo=max(0, -min(offsets)), pad_hi=max(0, max(offsets)))
    with jax.enable_x64(True):
        args = [jnp.asarray(a) for a in (P, mdp.reward, mdp.terminal_reward)]
        rev = [jnp.asarray(a) for a in demo_steps(mdp, demos)]
        return run_blocks(mdp, masks_of, n, block_size(mdp, max(n, 1)),
                          lambda forbidden: _kernel()(*args, jnp.asarray(forbidden), *rev, **statics))


def _collect(item, V0, log_lik):
    block, (V, ll, infeasible) = item
    k = block.stop - block.start
    V, ll, infeasible = (np.asarray(a)[..., :k] for a in (V, ll, infeasible))
    V0[:, block] = np.where(V <= DEAD, -np.inf, V)
    log_lik[block] = np.where(infeasible, -np.inf, ll)
