"""Legibility against several distractors at once: the QP of section 6.5,
``min J1 s.t. J1 - J0_i <= eta_i``, and its receding-horizon form.

Two formulations of the same problem:

* ``"sparse"`` (default): states and controls are both variables and the dynamics are
  equality constraints, so the solver's KKT matrix is banded and its cost grows linearly
  with the horizon ``N``;
* ``"dense"``: the dynamics are eliminated (the lifted form of :mod:`mutual.motion.observer`), so the
  variables are the ``N m`` stacked controls and the cost grows like ``N^2`` to ``N^3``.
  It stays for cross-checks and for hypotheses whose ``J1 - J0_i`` is convex in the controls
  but not stage by stage (then the sparse form would not be a convex program as written).
"""

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from ..observer import lifted_cost, lifted_dynamics


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


def _stacked(cost, N, n, m):
    """``J = 1/2 z'Pz + p'z + const`` over ``z = (x_0 .. x_N, u_0 .. u_{N-1})``: ``(P, p, const)``."""
    c = cost.stages(0, N)
    Q, R = np.broadcast_to(c.Q, (N, n, n)), np.broadcast_to(c.R, (N, m, m))
    P = sp.block_diag(list(Q) + [c.QN] + list(R), format="csc")
    p = np.concatenate([np.broadcast_to(c.q, (N, n)).ravel(), c.qN, np.broadcast_to(c.r, (N, m)).ravel()])
    blocks = list(Q) + [c.QN] + list(R)
    return P, p, c.const, blocks


def _blockwise_psd(blocks, tol):
    """Smallest eigenvalue over the diagonal blocks relative to their largest entry (>= -tol: PSD)."""
    scale = max(np.abs(b).max() for b in blocks)
    if scale == 0:
        return 0.0, True, scale
    low = min(np.linalg.eigvalsh(b)[0] for b in blocks)
    return low, low >= -tol * scale, scale


def _solve(prob, solver, etas):
    try:
        prob.solve(solver=solver)
    except cp.error.SolverError:
        raise ValueError(f"the multi-distractor QP for etas={etas.tolist()} defeated the solver {solver} (numerical "
                         "trouble: an eta at or near the smallest bound any motion meets, or costs of very different "
                         "scales)") from None
    if prob.status not in ("optimal", "optimal_inaccurate"):
        why = {"infeasible": ": no motion has J1 - J0_i <= eta_i for every distractor"}.get(prob.status, "")
        raise ValueError(f"the multi-distractor QP is {prob.status} for etas={etas.tolist()}{why}")


def multi_distractor_qp(dynamics, J1, distractors, x0, N, etas, solver="CLARABEL", tol=1e-9, formulation="sparse"):
    """Solve ``min J1 s.t. J1 - J0_i <= eta_i`` for every distractor ``J0_i`` (section 6.5) in cvxpy.

    Each constraint is affine when the quadratic parts of ``J1`` and ``J0_i`` cancel (x' = u with
    eq. (6.17)) and a convex quadratic when their difference is positive semidefinite; otherwise
    the problem is not convex and a ValueError is raised. ``formulation``: ``"sparse"`` (states as
    variables, banded, linear in ``N``; falls back to ``"dense"`` when a difference is convex only
    after eliminating the dynamics) or ``"dense"`` (controls only). Returns ``(xs, us, duals)``;
    ``duals[i]`` is the multiplier of constraint i, so the solution minimises
    ``(1 + sum duals) J1 - sum duals_i J0_i`` (the Lagrangian).
    """
    distractors, x0, etas = _check(dynamics, J1, distractors, x0, N, etas)
    if formulation not in ("sparse", "dense"):
        raise ValueError(f"formulation must be 'sparse' or 'dense', got {formulation!r}")
    if formulation == "sparse":
        out = _sparse_qp(dynamics, J1, distractors, x0, N, etas, solver, tol)
        if out is not None:
            return out
    return _dense_qp(dynamics, J1, distractors, x0, N, etas, solver, tol)


def dynamics_constraints(dynamics, x0, N):
    """The dynamics ``x_0 = x0, x_{k+1} = A_k x_k + B_k u_k`` as ``E z = e`` over
    ``z = (x_0 .. x_N, u_0 .. u_{N-1})`` (sparse ``E``); returns ``(E, e)``."""
    n, m = dynamics.n, dynamics.m
    dyn = dynamics.stages(0, N)
    A, B = np.broadcast_to(dyn.A, (N, n, n)), np.broadcast_to(dyn.B, (N, n, m))
    nx = (N + 1) * n
    shift = sp.vstack([sp.csr_matrix((n, N * n)), sp.block_diag(list(A), format="csr")])
    Ex = sp.eye(nx, format="csr") - sp.hstack([shift, sp.csr_matrix((nx, n))])
    Eu = -sp.vstack([sp.csr_matrix((n, N * m)), sp.block_diag(list(B), format="csr")])
    e = np.zeros(nx)
    e[:n] = x0
    return sp.hstack([Ex, Eu]).tocsc(), e


def stacked_cost(cost, N, n, m):
    """``J = 1/2 z'Pz + p'z + const`` over ``z = (x_0 .. x_N, u_0 .. u_{N-1})``: ``(P sparse, p, const)``."""
    return _stacked(cost, N, n, m)[:3]


def _sparse_qp(dynamics, J1, distractors, x0, N, etas, solver, tol):
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
    _solve(prob, solver, etas)
    xs = z.value[:nx].reshape(N + 1, n)
    xs[0] = x0
    us = z.value[nx:].reshape(N, m)
    return xs, us, np.array([c.dual_value for c in cons[1:]], dtype=float).reshape(-1)


def _dense_qp(dynamics, J1, distractors, x0, N, etas, solver, tol):
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
    _solve(prob, solver, etas)
    us = u.value.reshape(N, -1)
    free, G = lifted_dynamics(dynamics, x0, N)
    xs = free + G @ u.value
    return xs, us, np.array([c.dual_value for c in cons], dtype=float).reshape(-1)


def receding_horizon_qp(dynamics, J1, distractors, x0, N, eta_of_s, every=10, solver="CLARABEL"):
    """Anticipative multi-distractor control: replan :func:`multi_distractor_qp` every ``every``
    steps on the remaining horizon with ``eta = eta_of_s(t_i / N)`` (an increasing, i.e.
    loosening, schedule plays the role of the increasing alpha of eq. (6.16)).
    Returns ``(xs, us)``."""
    if not isinstance(every, (int, np.integer)) or every < 1:
        raise ValueError(f"every must be a positive integer, got {every!r}")
    if not callable(eta_of_s):
        raise ValueError(f"eta_of_s must be a function of s = t / N in [0, 1], got {eta_of_s!r}")
    distractors, x0, _ = _check(dynamics, J1, distractors, x0, N, 0.0)
    xs, us = [x0], []
    for start in range(0, N, every):
        rest = N - start
        plan_x, plan_u, _ = multi_distractor_qp(
            dynamics.stages(start, rest), J1.stages(start, rest), [J.stages(start, rest) for J in distractors],
            xs[-1], rest, eta_of_s(start / N), solver=solver)
        steps = min(every, rest)
        us.extend(plan_u[:steps])
        xs.extend(plan_x[1:steps + 1])
    return np.array(xs), np.array(us)
