"""The finite-horizon Riccati recursion of :mod:`mutual.motion.legible.lqr`, compiled (JAX, float64).

Same problem, same answer (to rounding) as the reference NumPy recursion; used through
``solve_lq(..., backend="jax")``. What makes it fast on a CPU for the small matrices of
motion problems (n <= 12 states, m <= 6 controls):

* one ``jax.lax.scan`` backward (gains) and one forward (rollout), jit-compiled;
* matrix products written as broadcast multiply-and-sum, so XLA fuses each stage into a few
  loops instead of calling a BLAS kernel per product;
* each stage is :func:`mutual.motion.riccati.riccati_step` (the step every Riccati recursion of the
  package takes), whose Cholesky factorisation of ``Q_uu = R + B'VB`` is unrolled into scalar
  arithmetic at trace time for ``m <= 4`` (LAPACK's ``potrf`` has a fixed cost per call, which
  pays off from about m = 5: measured 1.6 vs 1.9 ms at m = 4 and 4.8 vs 2.9 ms at m = 6, N = 1000);
* horizons padded up to a few lengths per octave (:func:`bucket`) with the padding stages
  masked out, so replanning on shrinking horizons reuses one compiled function.

Compiling costs about a second per (padded length, n, m, which arrays vary per stage);
:func:`mutual.motion.legible.lqr.solve_lq` reports unbounded problems from the Cholesky pivots
(a pivot <= 1e-9 times the stage's scale), see its docstring.
"""

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from ..riccati import LQStage, mm, mv, riccati_step

MIN_BUCKET = 16
FIELDS = ("A", "B", "Q", "R", "q", "r", "M", "c")


def bucket(N):
    """The padded horizon for ``N`` stages: at least 16, then four lengths per octave (<= 25% padding)."""
    if N <= MIN_BUCKET:
        return MIN_BUCKET
    step = 2 ** (int(np.floor(np.log2(N))) - 2)
    return int(-(-N // step) * step)


@partial(jax.jit, static_argnames=("per_stage",))
def _solve(arrays, QN, qN, x0, pad, per_stage):
    """Backward and forward passes over ``pad + N`` stages, of which the first ``pad`` are inert."""
    varying = {f: a for f, a in arrays.items() if f in per_stage}
    fixed = {f: a for f, a in arrays.items() if f not in per_stage}
    t_all = jnp.arange(next(iter(varying.values())).shape[0])

    def stage(s):
        return {f: (s[f] if f in per_stage else fixed[f]) for f in FIELDS}

    def back(carry, s):
        V, v = carry
        p = stage(s)
        F = jnp.concatenate([p["A"], p["B"]], axis=1)
        H = jnp.block([[p["Q"], p["M"]], [p["M"].T, p["R"]]])
        step = riccati_step(V, v, LQStage(F=F, H=H, g=jnp.concatenate([p["q"], p["r"]]), c=p["c"]), jnp)
        BVB = mm(jnp, p["B"].T, mm(jnp, V, p["B"]))
        scale = jnp.abs(p["R"]).max() + jnp.abs(BVB).max()
        active = s["t"] >= pad
        V_out, v_out = jnp.where(active, step.V, V), jnp.where(active, step.v, v)
        root = jnp.min(jnp.diagonal(step.L))                 # the smallest pivot's root; NaN for a negative pivot
        return (V_out, v_out), (step.K, step.k, V_out, v_out, root * root, scale)

    xs_back = {**varying, "t": t_all}
    _, (K, k, V, v, pivots, scales) = jax.lax.scan(back, (QN, qN), xs_back, reverse=True)

    def fwd(x, s):
        p = stage(s)
        u = mv(jnp, s["K"], x) + s["k"]
        active = s["t"] >= pad
        xn = jnp.where(active, mv(jnp, p["A"], x) + mv(jnp, p["B"], u) + p["c"], x)
        u = jnp.where(active, u, 0.0)
        return xn, (x, u)

    xN, (xs, us) = jax.lax.scan(fwd, x0, {**varying, "t": t_all, "K": K, "k": k})
    live = (t_all >= pad)[:, None]
    xs_l, us_l = jnp.where(live, xs, 0.0), us               # padding stages: x = x0 there, u = 0

    def quad(f, a, b):
        spec = "ki,kij,kj->" if f in per_stage else "ki,ij,kj->"
        return jnp.einsum(spec, a, arrays[f], b)

    def lin(f, a):
        return jnp.einsum("ki,ki->" if f in per_stage else "i,ki->", arrays[f], a)

    cost = (0.5 * quad("Q", xs_l, xs_l) + lin("q", xs_l) + 0.5 * quad("R", us_l, us_l) + lin("r", us_l)
            + quad("M", xs_l, us_l) + 0.5 * xN @ QN @ xN + qN @ xN)
    return xs, xN, us, K, k, V, v, pivots, scales, cost


def padded_arrays(stages, N, per_stage=None):
    """``(arrays, pad, per_stage)``: the stage arrays as the compiled recursion takes them, padded to
    :func:`bucket` ``(N)`` stages; ``per_stage`` (default: the fields whose arrays vary per stage)."""
    if per_stage is None:
        per_stage = tuple(f for f in FIELDS if N > 1 and stages[f].strides[0] != 0)
    if not per_stage:                       # the scan needs one per-stage array for its length
        per_stage = ("q",)
    pad = bucket(N) - N
    arrays = {}
    for f in FIELDS:
        a = np.asarray(stages[f])
        if f in per_stage:
            a = np.concatenate([np.repeat(a[:1], pad, axis=0), a]) if pad else np.ascontiguousarray(a)
        else:
            a = np.ascontiguousarray(a[0])
        arrays[f] = a
    return arrays, pad, tuple(per_stage)


def riccati_compiled(stages, QN, qN, x0, N):
    """Solve the LQ problem of :func:`mutual.motion.legible.lqr.solve_lq` with the compiled recursion.

    ``stages`` maps each of ``A, B, Q, R, q, r, M, c`` to its (N, ...) array (a broadcast view of
    a time-invariant array is passed once, not per stage). Returns NumPy arrays
    ``xs (N+1, n), us (N, m), K, k, V (N+1, n, n), v (N+1, n), pivots (N,), scales (N,), cost``.
    """
    arrays, pad, per_stage = padded_arrays(stages, N)
    with jax.enable_x64(True):
        out = _solve(arrays, np.asarray(QN), np.asarray(qN), np.asarray(x0), pad, per_stage)
        xs, xN, us, K, k, V, v, pivots, scales, cost = (np.asarray(o) for o in out)
    xs = np.concatenate([xs[pad:], xN[None]])
    V = np.concatenate([V[pad:], np.asarray(QN)[None]])
    v = np.concatenate([v[pad:], np.asarray(qN)[None]])
    return xs, us[pad:], K[pad:], k[pad:], V, v, pivots[pad:], scales[pad:], float(cost)


def solve_flops(stages, QN, qN, x0, N, combine=None):
    """XLA's static count of floating-point operations of one compiled solve (backward and forward
    passes). ``combine``: None for the problem as given, or ``(w1, w0, stages0, QN0, qN0)`` to count a
    program that first forms the cost ``w1 J - w0 J0`` stage by stage from both hypotheses' arrays
    and then solves it (Corollary 6.4.2.1's legible objective, eq. (6.15)). A count, not a timing."""
    others = None if combine is None else combine[2]
    varying = tuple(f for f in FIELDS if N > 1 and (stages[f].strides[0] != 0
                                                   or (others is not None and others[f].strides[0] != 0)))
    arrays, pad, per_stage = padded_arrays(stages, N, varying)
    with jax.enable_x64(True):
        if combine is None:
            fn = jax.jit(lambda a, QN_, qN_, x: _solve(a, QN_, qN_, x, pad, per_stage))
            lowered = fn.lower(arrays, np.asarray(QN), np.asarray(qN), np.asarray(x0))
        else:
            w1, w0, stages0, QN0, qN0 = combine
            arrays0 = padded_arrays(stages0, N, per_stage)[0]
            cost_fields = ("Q", "R", "q", "r", "M")

            def legible(a1, a0, QN1, QN0_, qN1, qN0_, x):
                mixed = {f: (w1 * a1[f] - w0 * a0[f]) if f in cost_fields else a1[f] for f in FIELDS}
                return _solve(mixed, w1 * QN1 - w0 * QN0_, w1 * qN1 - w0 * qN0_, x, pad, per_stage)
            lowered = jax.jit(legible).lower(arrays, arrays0, np.asarray(QN), np.asarray(QN0), np.asarray(qN),
                                             np.asarray(qN0), np.asarray(x0))
        analysis = lowered.compile().cost_analysis()
    analysis = analysis[0] if isinstance(analysis, (list, tuple)) else analysis
    return float(analysis["flops"])
