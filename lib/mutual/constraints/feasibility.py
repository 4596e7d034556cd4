"""Which candidate constraint sets leave some demonstration without a trajectory, found without
computing a single soft value: the -inf pattern of Algorithm 4 by a boolean backup.

A state is *dead* at time t under Phi_C when every action it offers is forbidden or reaches, with
positive probability, a state dead at t + 1 (then V_{C,t} = -inf, eq. 2.21; no state is dead at
T). A candidate makes the demonstrations infeasible (likelihood 0) exactly when some demonstrated
(x_t, a_t) is forbidden or reaches a state dead at t + 1. With slip and no loiter away from the
goal, one forbidden neighbourhood kills a whole grid this way (Section 3.3's set-up), so most
hard (psi = 0) candidates are infeasible; :func:`infeasible_candidates` finds them for 32
candidates per machine word, on grids by a compiled stencil (:mod:`.fast`), on large MDPs with few
successors per state-action pair (discretized continuous systems) by the compiled gather form,
elsewhere by a sparse boolean product.
"""

import numpy as np
import scipy.sparse as sp

from . import fast, gather as _gather
from .reachable import restricted

_KERNELS = {}
GATHER_ROWS = 2 ** 14   # state-action pairs X * A from which a non-grid MDP uses the compiled gather form
GATHER_WORDS = 4        # ... for 32 x GATHER_WORDS candidates per call (one compiled shape)


def _kernel(kind):
    """The jitted boolean backup for S in stencil form (``"stencil"``) or gather form (``"gather"``)."""
    if kind not in _KERNELS:
        import jax
        import jax.numpy as jnp

        def run(reaches, index, extra, forbidden, dx, da, valid, offsets, pad_lo, pad_hi):
            X, A, W = forbidden.shape
            extra_index, extra_reaches = extra

            def refresh(dead):
                """The gather form's auxiliary rows: dead if any of their successors is."""
                if kind == "stencil":
                    return dead
                aux = jnp.zeros((extra_index.shape[0], W), dtype=jnp.uint32)
                for e in range(extra_index.shape[1]):
                    aux = aux | jnp.where(extra_reaches[:, e, None], dead[extra_index[:, e]], jnp.uint32(0))
                return jax.lax.dynamic_update_slice_in_dim(dead, aux, X, axis=0)

            def step(carry, inputs):
                dead, infeasible = carry
                x_t, a_t, ok = inputs
                reach = jnp.zeros_like(forbidden)
                if kind == "stencil":
                    padded = jnp.pad(dead, ((pad_lo, pad_hi), (0, 0)))
                    for j, o in enumerate(offsets):
                        shifted = jax.lax.slice_in_dim(padded, pad_lo + o, pad_lo + o + X)
                        reach = reach | jnp.where(reaches[:, :, j, None], shifted[:, None, :], jnp.uint32(0))
                else:
                    for j in range(reaches.shape[2]):
                        reach = reach | jnp.where(reaches[:, :, j, None], dead[index[:, :, j]], jnp.uint32(0))
                bad = forbidden | reach
                now = bad[:, 0]
                for a in range(1, A):
                    now = now & bad[:, a]
                dead = refresh(jax.lax.dynamic_update_slice_in_dim(dead, now, 0, axis=0))
                lost = jax.lax.reduce(bad[x_t, a_t], jnp.uint32(0), jax.lax.bitwise_or, (0,))
                return (dead, jnp.where(ok, infeasible | lost, infeasible)), None

            rows = X + (extra_index.shape[0] if kind == "gather" else 0)
            init = (refresh(jnp.zeros((rows, W), dtype=jnp.uint32)), jnp.zeros(W, dtype=jnp.uint32))
            (_, infeasible), _ = jax.lax.scan(step, init, (dx, da, valid))
            return infeasible

        _KERNELS[kind] = jax.jit(run, static_argnames=("offsets", "pad_lo", "pad_hi"))
    return _KERNELS[kind]


def _padded(words):
    return np.pad(words, ((0, 0), (0, GATHER_WORDS - words.shape[1])))


def _run(kind, args, statics, words, dx, da, valid):
    import jax.numpy as jnp
    reaches, index, extra = args
    return np.asarray(_kernel(kind)(jnp.asarray(reaches), jnp.asarray(index), tuple(jnp.asarray(a) for a in extra),
                                    jnp.asarray(words), jnp.asarray(dx), jnp.asarray(da), jnp.asarray(valid), **statics))


def _unpack(words, K):
    """(W,) uint32 words -> K booleans, candidate k in bit k % 32 of word k // 32."""
    return np.unpackbits(np.ascontiguousarray(words).view(np.uint8), bitorder="little")[:K].astype(bool)


def infeasible_candidates(mdp, demos, base_mask, forbidden):
    """For the candidates Phi_C = ``base_mask`` (X, A) minus ``forbidden`` (sparse (X*A, K) or
    dense (X, A, K)): whether each leaves some demonstration infeasible (a demonstrated action
    forbidden, or reaching a dead state; module docstring). Returns (K,) booleans: exactly the
    candidates whose demonstration log-likelihood under Algorithm 4 is -inf."""
    base = np.asarray(base_mask, dtype=bool) & mdp.allowed
    form = fast.stencil_form(mdp)
    part = restricted(mdp, demos.states[:, 0]) if form is None else None
    if part is not None:        # only the states the starts reach matter (:mod:`.reachable`)
        mdp, demos, base, forbidden = part.mdp, part.demos(demos), part.mask(base), part.columns(forbidden)
    X, A = base.shape
    F = sp.coo_matrix(forbidden.reshape(X * A, -1) if not sp.issparse(forbidden) else forbidden)
    K = F.shape[1]
    gather = _gather.gather_form(mdp) if form is None and X * A >= GATHER_ROWS else None
    dx, da, valid = fast.demo_steps(mdp, demos)
    if form is not None or gather is not None:
        W = -(-K // 32)
        words = np.zeros((X * A, W), dtype=np.uint32)
        words[~base.ravel()] = np.uint32(0xFFFFFFFF)
        hit = F.data.astype(bool)
        np.bitwise_or.at(words, (F.row[hit], F.col[hit] // 32), (np.uint32(1) << (F.col[hit] % 32).astype(np.uint32)))
        if form is not None:
            offsets, P = form
            none = (np.zeros((1, 1), dtype=np.int32), np.zeros((1, 1), dtype=bool))
            args, statics = (P > 0, np.zeros((1, 1, 1), dtype=np.int32), none), dict(
                offsets=offsets, pad_lo=max(0, -min(offsets)), pad_hi=max(0, max(offsets)))
            return _unpack(_run("stencil", args, statics, words.reshape(X, A, W), dx, da, valid), K)
        args = (gather.P > 0, gather.index, (gather.extra_index, gather.extra_P > 0))
        statics = dict(offsets=(), pad_lo=0, pad_hi=0)
        out = [_run("gather", args, statics, _padded(words[:, w:w + GATHER_WORDS]).reshape(X, A, GATHER_WORDS),
                    dx, da, valid) for w in range(0, W, GATHER_WORDS)]       # one compiled shape for any K
        return _unpack(np.concatenate(out)[:W], K)
    masks = base[:, :, None] & ~F.toarray().astype(bool).reshape(X, A, K)
    reaches = sp.csr_matrix(mdp.transitions > 0, dtype=np.float64)
    dead = np.zeros((X, K), dtype=bool)
    infeasible = np.zeros(K, dtype=bool)
    for t_rev in range(mdp.horizon):
        bad = ~masks | (np.asarray(reaches @ dead.astype(float)) > 0).reshape(masks.shape)
        if valid[t_rev]:
            infeasible |= bad[dx[t_rev], da[t_rev]].any(axis=0)
        dead = bad.all(axis=1)
    return infeasible
