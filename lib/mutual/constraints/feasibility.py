"""Which candidate constraint sets leave some demonstration without a trajectory, found without
computing a single soft value: the -inf pattern of Algorithm 4 by a boolean backup.

A state is *dead* at time t under Phi_C when every action it offers is forbidden or reaches, with
positive probability, a state dead at t + 1 (then V_{C,t} = -inf, eq. 2.21; no state is dead at
T). A candidate makes the demonstrations infeasible (likelihood 0) exactly when some demonstrated
(x_t, a_t) is forbidden or reaches a state dead at t + 1. With slip and no loiter away from the
goal, one forbidden neighbourhood kills a whole grid this way (Section 3.3's set-up), so most
hard (psi = 0) candidates are infeasible; :func:`infeasible_candidates` finds them for 32
candidates per machine word, on grids by a compiled stencil (:mod:`.fast`), elsewhere by a
sparse boolean product.
"""

import numpy as np
import scipy.sparse as sp

from . import fast

_KERNEL = None


def _kernel():
    global _KERNEL
    if _KERNEL is None:
        import jax
        import jax.numpy as jnp

        def run(reaches, forbidden, dx, da, valid, offsets, pad_lo, pad_hi):
            X, A, W = forbidden.shape

            def step(carry, inputs):
                dead, infeasible = carry
                x_t, a_t, ok = inputs
                padded = jnp.pad(dead, ((pad_lo, pad_hi), (0, 0)))
                reach = jnp.zeros_like(forbidden)
                for j, o in enumerate(offsets):
                    shifted = jax.lax.slice_in_dim(padded, pad_lo + o, pad_lo + o + X)
                    reach = reach | jnp.where(reaches[:, :, j, None], shifted[:, None, :], jnp.uint32(0))
                bad = forbidden | reach
                dead = bad[:, 0]
                for a in range(1, A):
                    dead = dead & bad[:, a]
                lost = jax.lax.reduce(bad[x_t, a_t], jnp.uint32(0), jax.lax.bitwise_or, (0,))
                return (dead, jnp.where(ok, infeasible | lost, infeasible)), None

            init = (jnp.zeros((X, W), dtype=jnp.uint32), jnp.zeros(W, dtype=jnp.uint32))
            (_, infeasible), _ = jax.lax.scan(step, init, (dx, da, valid))
            return infeasible

        _KERNEL = jax.jit(run, static_argnames=("offsets", "pad_lo", "pad_hi"))
    return _KERNEL


def _unpack(words, K):
    """(W,) uint32 words -> K booleans, candidate k in bit k % 32 of word k // 32."""
    return np.unpackbits(np.ascontiguousarray(words).view(np.uint8), bitorder="little")[:K].astype(bool)


def _demo_steps(mdp, demos):
    T = mdp.horizon
    dx = np.zeros((T, demos.n), dtype=np.int32)
    da = np.zeros_like(dx)
    dx[: demos.steps], da[: demos.steps] = demos.states[:, :-1].T, demos.actions.T
    return dx[::-1].copy(), da[::-1].copy(), (np.arange(T) < demos.steps)[::-1].copy()


def infeasible_candidates(mdp, demos, base_mask, forbidden):
    """For the candidates Phi_C = ``base_mask`` (X, A) minus ``forbidden`` (sparse (X*A, K) or
    dense (X, A, K)): whether each leaves some demonstration infeasible (a demonstrated action
    forbidden, or reaching a dead state; module docstring). Returns (K,) booleans: exactly the
    candidates whose demonstration log-likelihood under Algorithm 4 is -inf."""
    base = np.asarray(base_mask, dtype=bool) & mdp.allowed
    X, A = base.shape
    F = sp.coo_matrix(forbidden.reshape(X * A, -1) if not sp.issparse(forbidden) else forbidden)
    K = F.shape[1]
    form = fast.stencil_form(mdp)
    dx, da, valid = _demo_steps(mdp, demos)
    if form is not None:
        import jax.numpy as jnp

        W = -(-K // 32)
        words = np.zeros((X * A, W), dtype=np.uint32)
        words[~base.ravel()] = np.uint32(0xFFFFFFFF)
        hit = F.data.astype(bool)
        np.bitwise_or.at(words, (F.row[hit], F.col[hit] // 32), (np.uint32(1) << (F.col[hit] % 32).astype(np.uint32)))
        offsets, P = form
        out = _kernel()(jnp.asarray(P > 0), jnp.asarray(words.reshape(X, A, W)), jnp.asarray(dx), jnp.asarray(da),
                        jnp.asarray(valid), offsets=offsets, pad_lo=max(0, -min(offsets)),
                        pad_hi=max(0, max(offsets)))
        return _unpack(np.asarray(out), K)
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
