"""The backward pass of iLQR/DDP (Tassa, Erez & Todorov 2012, eqs. (5)-(11); Todorov & Li 2005,
section 3): from the terminal cost back to the start, the quadratic model of the cost-to-go

    Q_z = g + F'v,    Q_zz = H + F'V F  (+ sum_i v_i f_i'' for DDP, eq. (6)),

the regularised policy ``du = k + K dx`` with ``(Q_uu + mu c I) [k K] = -[Q_u Q_ux]`` (eq. (10),
the control-space regularisation of section II-F) and the cost-to-go update with the
unregularised ``Q_uu`` (eq. (11)): each stage is :func:`mutual.motion.riccati.riccati_step`, the step
every Riccati recursion of the package takes. ``d1 = sum k'Q_u`` and ``d2 = sum 1/2 k'Q_uu k`` give the
model's predicted decrease ``-(a d1 + a^2 d2)`` for a step of size ``a`` (eq. (13)).
"""

import jax
import jax.numpy as jnp

from ..riccati import LQStage, mv, positive_definite, riccati_step


def _stage(carry, stage, reg, n, curvature_weight):
    """One stage of the recursion: ``(V, v)`` at ``k + 1`` to ``(V, v)`` at ``k`` and the gains ``[k K]``."""
    V, v, d1, d2, every_ok = carry
    F, g, H = stage[:3]
    curvature = None
    if len(stage) > 3:  # DDP: + sum_i v_i f_i''
        curvature = curvature_weight * jnp.sum(v[:, None, None] * stage[3], axis=0)
    step = riccati_step(V, v, LQStage(F=F, H=H, g=g), jnp, reg=reg, curvature=curvature)
    k = step.k
    d1 = d1 + jnp.sum(k * step.Q_u)
    d2 = d2 + 0.5 * jnp.sum(k * mv(jnp, step.Q_uu, k))
    return (step.V, step.v, d1, d2, every_ok & positive_definite(step.L)), step.gains


def backward_pass(model, mu, curvature_weight=1.0):
    """Gains ``G = [k K]`` (N, m, 1+n), the predicted terms ``d1`` and ``d2``, and whether every
    ``Q_uu + mu c I`` was positive definite, for the :class:`.model.Model` ``model``."""
    n = model.VN.shape[0]
    m = model.H.shape[-1] - n
    reg = mu * model.c * jnp.eye(m)
    stages = (model.F, model.g, model.H) if model.curvature is None else (model.F, model.g, model.H, model.curvature)
    zero = jnp.zeros(())
    # not unrolled: unroll=4 compiled 1.5-2x slower and ran no faster (JAX 0.10, CPU)
    (_, _, d1, d2, ok), G = jax.lax.scan(lambda carry, stage: _stage(carry, stage, reg, n, curvature_weight),
                                         (model.VN, model.vN, zero, zero, jnp.ones((), bool)), stages, reverse=True)
    return G, d1, d2, ok
