"""Legibility against several distractors at once: the QP of section 6.5,
``min J1 s.t. J1 - J0_i <= eta_i``, and its receding-horizon form.

Solvers: ``"active-set"`` when every constraint is affine (the hypotheses share their quadratic parts, as
eq. (6.17)'s do): the banded KKT system of the dynamics is factored once, and the multipliers come from the
small dual over the few constraints (every active set is tried, smallest first); no cvxpy. Any other name is a
cvxpy solver (default Clarabel, an interior point method), in one of two formulations of the same problem:

* ``"sparse"`` (default): states and controls are both variables and the dynamics are
  equality constraints, so the solver's KKT matrix is banded and its cost grows linearly
  with the horizon ``N``;
* ``"dense"``: the dynamics are eliminated (the lifted form of :mod:`mutual.motion.observer`), so the
  variables are the ``N m`` stacked controls and the cost grows like ``N^2`` to ``N^3``.
  It stays for cross-checks and for hypotheses whose ``J1 - J0_i`` is convex in the controls
  but not stage by stage (then the sparse form would not be a convex program as written).
"""

import hashlib
import itertools

import cvxpy as cp
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..observer import lifted_cost, lifted_dynamics
from .problem import solve


def _check(dynamics, J1, distractors, x0, N, etas):
    if not hasattr(dynamics, "stages"):
        raise ValueError(f"dynamics must be a LinearDynamics, got {type(dynamics).__name__}")
    if not isinstance(N, (int, np.integer)) or isinstance(N, bool) or N < 1:
        raise ValueError(f"N must be a positive integer, got {N!r}")
    distractors = list(distractors) if not hasattr(distractors, "QN") else [distractors]
    if not distractors:
        raise ValueError("distractors must list at least one hypothesis cost")
    for i, J in enumerate([J1] + distractors):
        if not hasattr(J, "QN"):
            name = "J1" if i == 0 else f"distractors[{i - 1}]"
            raise ValueError(f"{name} must be a QuadraticCost, got {type(J).__name__}")
        if (J.QN.shape[0], J.R.shape[-1]) != (dynamics.n, dynamics.m):
            name = "J1" if i == 0 else f"distractors[{i - 1}]"
            raise ValueError(f"{name} is a cost for n = {J.QN.shape[0]}, m = {J.R.shape[-1]}; the dynamics have "
                             f"n = {dynamics.n}, m = {dynamics.m}")
    x0 = np.asarray(x0, float)
    if x0.shape != (dynamics.n,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be a finite vector of length {dynamics.n}, got {x0!r}")
    try:
        etas = np.broadcast_to(np.asarray(etas, float), (len(distractors),))
    except ValueError:
        raise ValueError(f"etas must be a number or one per distractor ({len(distractors)}), got {etas!r}") from None
    if not np.all(np.isfinite(etas)):
        raise ValueError(f"etas must be finite, got {etas.tolist()}")
    return distractors, x0, etas


def _block_diag(blocks):
    """The block-diagonal sparse matrix of ``blocks`` (K, r, c), built from index arrays (no Python loop)."""
    K, r, c = blocks.shape
    i = np.arange(K)[:, None, None] * r + np.arange(r)[None, :, None]
    j = np.arange(K)[:, None, None] * c + np.arange(c)[None, None, :]
    rows, cols = np.broadcast_to(i, blocks.shape).ravel(), np.broadcast_to(j, blocks.shape).ravel()
    return sp.csr_matrix((np.ravel(blocks), (rows, cols)), shape=(K * r, K * c))


def _terms(cost, N, n, m):
    """``(p, const, blocks)`` of :func:`_stacked` without assembling ``P``."""
    c = cost.stages(0, N)
    Qs = np.concatenate([np.broadcast_to(c.Q, (N, n, n)), c.QN[None]])
    Rs = np.broadcast_to(c.R, (N, m, m))
    p = np.concatenate([np.broadcast_to(c.q, (N, n)).ravel(), c.qN, np.broadcast_to(c.r, (N, m)).ravel()])
    return p, c.const, (Qs, Rs)


def _stacked(cost, N, n, m):
    """``J = 1/2 z'Pz + p'z + const`` over ``z = (x_0 .. x_N, u_0 .. u_{N-1})``: ``(P, p, const, blocks)``,
    ``blocks`` the diagonal blocks of ``P``: states (N+1, n, n) and controls (N, m, m)."""
    p, const, (Qs, Rs) = _terms(cost, N, n, m)
    return sp.block_diag([_block_diag(Qs), _block_diag(Rs)], format="csc"), p, const, (Qs, Rs)


def _blockwise_psd(blocks, tol):
    """Smallest eigenvalue over the diagonal blocks relative to their largest entry (>= -tol: PSD)."""
    scale = max(np.abs(b).max() for b in blocks)
    if scale == 0:
        return 0.0, True, scale
    low = min(np.linalg.eigvalsh(b)[:, 0].min() for b in blocks)
    return low, low >= -tol * scale, scale


def _solve(prob, solver, etas, options=None):
    try:
        prob.solve(solver=solver, **(options or {}))
    except cp.error.SolverError:
        raise ValueError(f"the multi-distractor QP for etas={etas.tolist()} defeated the solver {solver} (numerical "
                         "trouble: an eta at or near the smallest bound any motion meets, or costs of very different "
                         "scales)") from None
    if prob.status not in ("optimal", "optimal_inaccurate"):
        why = {"infeasible": ": no motion has J1 - J0_i <= eta_i for every distractor"}.get(prob.status, "")
        raise ValueError(f"the multi-distractor QP is {prob.status} for etas={etas.tolist()}{why}")


def multi_distractor_qp(dynamics, J1, distractors, x0, N, etas, solver="CLARABEL", tol=1e-9, formulation="sparse",
                        solver_options=None):
    """Solve ``min J1 s.t. J1 - J0_i <= eta_i`` for every distractor ``J0_i`` (section 6.5) in cvxpy.

    Each constraint is affine when the quadratic parts of ``J1`` and ``J0_i`` cancel (x' = u with
    eq. (6.17)) and a convex quadratic when their difference is positive semidefinite; otherwise
    the problem is not convex and a ValueError is raised. ``formulation``: ``"sparse"`` (states as
    variables, banded, linear in ``N``; falls back to ``"dense"`` when a difference is convex only
    after eliminating the dynamics) or ``"dense"`` (controls only). Returns ``(xs, us, duals)``;
    ``duals[i]`` is the multiplier of constraint i, so the solution minimises
    ``(1 + sum duals) J1 - sum duals_i J0_i`` (the Lagrangian). ``solver="active-set"``: see the module
    docstring (affine constraints only; a ValueError otherwise). ``solver_options`` go to cvxpy's solve.
    """
    distractors, x0, etas = _check(dynamics, J1, distractors, x0, N, etas)
    if solver == "active-set":
        return active_set_qp(dynamics, J1, distractors, x0, N, etas, tol)
    if formulation not in ("sparse", "dense"):
        raise ValueError(f"formulation must be 'sparse' or 'dense', got {formulation!r}")
    if formulation == "sparse":
        out = _sparse_qp(dynamics, J1, distractors, x0, N, etas, solver, tol, solver_options)
        if out is not None:
            return out
    return _dense_qp(dynamics, J1, distractors, x0, N, etas, solver, tol, solver_options)


def dynamics_constraints(dynamics, x0, N):
    """The dynamics ``x_0 = x0, x_{k+1} = A_k x_k + B_k u_k`` as ``E z = e`` over
    ``z = (x_0 .. x_N, u_0 .. u_{N-1})`` (sparse ``E``); returns ``(E, e)``."""
    n, m = dynamics.n, dynamics.m
    dyn = dynamics.stages(0, N)
    A, B = np.broadcast_to(dyn.A, (N, n, n)), np.broadcast_to(dyn.B, (N, n, m))
    nx = (N + 1) * n
    shift = sp.vstack([sp.csr_matrix((n, N * n)), _block_diag(A)])
    Ex = sp.eye(nx, format="csr") - sp.hstack([shift, sp.csr_matrix((nx, n))])
    Eu = -sp.vstack([sp.csr_matrix((n, N * m)), _block_diag(B)])
    e = np.zeros(nx)
    e[:n] = x0
    return sp.hstack([Ex, Eu]).tocsc(), e


def stacked_cost(cost, N, n, m):
    """``J = 1/2 z'Pz + p'z + const`` over ``z = (x_0 .. x_N, u_0 .. u_{N-1})``: ``(P sparse, p, const)``."""
    return _stacked(cost, N, n, m)[:3]


def _sparse_qp(dynamics, J1, distractors, x0, N, etas, solver, tol, options=None):
    n, m = dynamics.n, dynamics.m
    nx = (N + 1) * n
    E, e = dynamics_constraints(dynamics, x0, N)
    P1, p1, c1, blocks1 = _stacked(J1, N, n, m)
    if not _blockwise_psd(blocks1, tol)[1]:
        return None
    z = cp.Variable(nx + N * m)
    cons = [E @ z == e]
    for i, J0 in enumerate(distractors):
        P0, p0, c0, blocks0 = _stacked(J0, N, n, m)
        diff = [b1 - b0 for b1, b0 in zip(blocks1, blocks0)]
        affine = (p1 - p0) @ z + (c1 - c0)
        low, psd, scale = _blockwise_psd(diff, tol)
        if scale <= tol * max(1.0, max(np.abs(b).max() for b in blocks1)):
            cons.append(affine <= etas[i])
        elif psd:
            cons.append(0.5 * cp.quad_form(z, cp.psd_wrap(P1 - P0)) + affine <= etas[i])
        else:
            return None                      # maybe convex in u only: let the dense form decide
    prob = cp.Problem(cp.Minimize(0.5 * cp.quad_form(z, cp.psd_wrap(P1)) + p1 @ z), cons)
    _solve(prob, solver, etas, options)
    xs = z.value[:nx].reshape(N + 1, n)
    xs[0] = x0
    us = z.value[nx:].reshape(N, m)
    return xs, us, np.array([c.dual_value for c in cons[1:]], dtype=float).reshape(-1)


ACTIVE_SET_MAX = 12          # constraints the active-set solver enumerates (2^12 active sets at most)


def affine_constraints(dynamics, J1, distractors, N):
    """``J1 - J0_i = a_i'z + c_i`` over ``z = (x_0 .. x_N, u_0 .. u_{N-1})`` when every ``J0_i`` shares ``J1``'s
    quadratic parts (relative difference at most 1e-12); returns ``(A, c)`` or None."""
    n, m = dynamics.n, dynamics.m
    p1, c1, blocks1 = _terms(J1, N, n, m)
    scale = max(1.0, max(np.abs(b).max() for b in blocks1))
    rows, consts = [], []
    for J0 in distractors:
        p0, c0, blocks0 = _terms(J0, N, n, m)
        if max(np.abs(b1 - b0).max() for b1, b0 in zip(blocks1, blocks0)) > 1e-12 * scale:
            return None
        rows.append(p1 - p0)
        consts.append(c1 - c0)
    return np.array(rows), np.array(consts)


_KKT_CACHE = {}
_KKT_CACHE_SIZE = 64


def _kkt_factor(dynamics, J1, N):
    """Sparse LU of ``[P E'; E 0]`` (``min J1`` under the dynamics), cached by the arrays it depends on: every
    goal and start of a scan, and every replan of the same length, share it."""
    n, m = dynamics.n, dynamics.m
    dyn, c = dynamics.stages(0, N), J1.stages(0, N)
    key = (N, n, m, hashlib.sha1(b"".join(np.ascontiguousarray(a, float).tobytes()
                                          for a in (dyn.A, dyn.B, c.Q, c.R, c.QN))).hexdigest())
    if key not in _KKT_CACHE:
        if len(_KKT_CACHE) >= _KKT_CACHE_SIZE:
            _KKT_CACHE.pop(next(iter(_KKT_CACHE)))
        E, _ = dynamics_constraints(dynamics, np.zeros(n), N)
        P = _stacked(J1, N, n, m)[0]
        _KKT_CACHE[key] = spla.splu(sp.bmat([[P, E.T], [E, None]], format="csc"))
    return _KKT_CACHE[key]


def _dual_active_set(M, r, tol):
    """``lambda >= 0`` with ``g = r - M lambda <= 0`` and ``lambda_i g_i = 0`` (the QP's KKT conditions in its
    multipliers), trying every active set, smallest first; None if none fits (the QP is infeasible)."""
    k = len(r)
    scale = tol * max(1.0, np.abs(r).max(), np.abs(M).max())
    for size in range(k + 1):
        for S in map(list, itertools.combinations(range(k), size)):
            lam = np.zeros(k)
            if S:
                lam[S] = np.linalg.lstsq(M[np.ix_(S, S)], r[S], rcond=None)[0]
            g = r - M @ lam
            if lam.min() >= -scale and g.max() <= scale and (not S or np.abs(g[S]).max() <= scale):
                return np.maximum(lam, 0.0)
    return None


def active_set_qp(dynamics, J1, distractors, x0, N, etas, tol=1e-9, free=False):
    """:func:`multi_distractor_qp` by an active set, for affine constraints ``J1 - J0_i <= eta_i``.

    The KKT system ``[P E'; E 0]`` of ``min J1`` under the dynamics ``E z = e`` (banded) is factored once;
    ``z(l) = z0 - W l`` for multipliers ``l``, so the constraints are ``r - M l <= 0`` with ``M = A W`` (k x k,
    symmetric positive semidefinite) and the multipliers solve that small complementarity problem
    (:func:`_dual_active_set`). Returns ``(xs, us, duals)`` like :func:`multi_distractor_qp`, and with
    ``free=True`` also the states of ``z0``, the plan without bounds."""
    distractors, x0, etas = _check(dynamics, J1, distractors, x0, N, etas)
    affine = affine_constraints(dynamics, J1, distractors, N)
    if affine is None:
        raise ValueError("the active-set solver needs affine constraints: every distractor must share J1's "
                         "quadratic parts (use a cvxpy solver, e.g. solver='CLARABEL')")
    if len(distractors) > ACTIVE_SET_MAX:
        raise ValueError(f"the active-set solver enumerates at most {ACTIVE_SET_MAX} constraints, got "
                         f"{len(distractors)} (use a cvxpy solver, e.g. solver='CLARABEL')")
    A, c = affine
    n, m = dynamics.n, dynamics.m
    nx = (N + 1) * n
    kkt = _kkt_factor(dynamics, J1, N)
    p = _terms(J1, N, n, m)[0]
    e = np.zeros(nx)
    e[:n] = x0                                    # the dynamics' right-hand side (dynamics_constraints)
    zeros = np.zeros((len(e), len(A)))
    sol = kkt.solve(np.column_stack([np.concatenate([-p, e]), np.vstack([A.T, zeros])]))
    z0, W = sol[:len(p), 0], sol[:len(p), 1:]
    lam = _dual_active_set(A @ W, A @ z0 + c - etas, tol)
    if lam is None:
        raise ValueError(f"the multi-distractor QP is infeasible for etas={etas.tolist()}: no motion has "
                         "J1 - J0_i <= eta_i for every distractor")
    z = z0 - W @ lam
    xs = z[:nx].reshape(N + 1, n)
    out = (xs, z[nx:].reshape(N, m), lam)
    return out + (z0[:nx].reshape(N + 1, n),) if free else out


def _dense_qp(dynamics, J1, distractors, x0, N, etas, solver, tol, options=None):
    H1, h1, c1 = lifted_cost(dynamics, J1, x0, N)
    u = cp.Variable(H1.shape[0])
    cons = []
    for i, J0 in enumerate(distractors):
        H0, h0, c0 = lifted_cost(dynamics, J0, x0, N)
        D = H1 - H0
        affine = (h1 - h0) @ u + (c1 - c0)
        if np.abs(D).max() <= tol * max(1.0, np.abs(H1).max()):
            cons.append(affine <= etas[i])
        elif np.linalg.eigvalsh(D)[0] >= -tol * np.abs(D).max():
            cons.append(0.5 * cp.quad_form(u, cp.psd_wrap(D)) + affine <= etas[i])
        else:
            raise ValueError(f"distractors[{i}]: J1 - J0 has an indefinite quadratic part, so the "
                             "constraint J1 - J0 <= eta is not convex")
    if np.linalg.eigvalsh(H1)[0] < -tol * max(1.0, np.abs(H1).max()):
        raise ValueError("J1 is not convex in the controls, so min J1 is not a convex program")
    prob = cp.Problem(cp.Minimize(0.5 * cp.quad_form(u, cp.psd_wrap(H1)) + h1 @ u), cons)
    _solve(prob, solver, etas, options)
    us = u.value.reshape(N, -1)
    free, G = lifted_dynamics(dynamics, x0, N)
    xs = free + G @ u.value
    return xs, us, np.array([c.dual_value for c in cons], dtype=float).reshape(-1)


def receding_horizon_qp(dynamics, J1, distractors, x0, N, eta_of_s, every=10, solver="CLARABEL", record=False):
    """Anticipative multi-distractor control: replan :func:`multi_distractor_qp` every ``every``
    steps on the remaining horizon with ``eta = eta_of_s(t_i / N)`` (a number, or one per distractor: the
    thesis's per-pair ``eta_i``; an increasing, i.e. loosening, schedule plays the role of the increasing
    alpha of eq. (6.16)). Returns ``(xs, us)``, and with ``record=True`` also one dict per replan:
    ``step``, ``etas``, ``duals``, the planned end point ``end`` and ``end_free``, where the same replan
    without bounds would end (how far the bounds moved the plan)."""
    if not isinstance(every, (int, np.integer)) or every < 1:
        raise ValueError(f"every must be a positive integer, got {every!r}")
    if not callable(eta_of_s):
        raise ValueError(f"eta_of_s must be a function of s = t / N in [0, 1], got {eta_of_s!r}")
    distractors, x0, _ = _check(dynamics, J1, distractors, x0, N, 0.0)
    xs, us, replans = [x0], [], []
    for start in range(0, N, every):
        rest = N - start
        dyn, cost = dynamics.stages(start, rest), J1.stages(start, rest)
        etas, others = eta_of_s(start / N), [J.stages(start, rest) for J in distractors]
        if solver == "active-set":
            plan_x, plan_u, duals, free_x = active_set_qp(dyn, cost, others, xs[-1], rest, etas, free=True)
        else:
            plan_x, plan_u, duals = multi_distractor_qp(dyn, cost, others, xs[-1], rest, etas, solver=solver)
            free_x = solve(dyn, cost, xs[-1], rest).xs if record else None
        if record:
            replans.append({"step": start, "etas": np.broadcast_to(np.asarray(etas, float), duals.shape).copy(),
                            "duals": duals, "end": plan_x[-1], "end_free": free_x[-1]})
        steps = min(every, rest)
        us.extend(plan_u[:steps])
        xs.extend(plan_x[1:steps + 1])
    return (np.array(xs), np.array(us), replans) if record else (np.array(xs), np.array(us))
