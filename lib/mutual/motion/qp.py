"""Legibility against several distractors at once: the QP of section 6.5 (eq. 6.17),
``min J1 s.t. J1 - J0_i <= eta_i``, and its receding-horizon form."""

import cvxpy as cp
import numpy as np

from .observer import lifted_cost, lifted_dynamics


def multi_distractor_qp(dynamics, J1, distractors, x0, N, etas, solver="CLARABEL", tol=1e-9):
    """Solve ``min J1 s.t. J1 - J0_i <= eta_i`` for every distractor ``J0_i`` (section 6.5) in cvxpy.

    Each constraint is affine in ``u`` when the quadratic parts of ``J1`` and ``J0_i``
    cancel (x' = u with eq. (6.17)) and a convex quadratic when ``H1 - H0_i`` is
    positive semidefinite; otherwise the problem is not convex and a ValueError is
    raised. Returns ``(xs, us, duals)``; ``duals[i]`` is the multiplier of constraint i,
    so the solution minimises ``(1 + sum duals) J1 - sum duals_i J0_i`` (the Lagrangian).
    """
    if not len(distractors):
        raise ValueError("distractors must list at least one hypothesis cost")
    try:
        etas = np.broadcast_to(np.asarray(etas, float), (len(distractors),))
    except ValueError:
        raise ValueError(f"etas must be a number or one per distractor ({len(distractors)}), got {etas!r}") from None
    if not np.all(np.isfinite(etas)):
        raise ValueError(f"etas must be finite, got {etas.tolist()}")
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
    prob = cp.Problem(cp.Minimize(0.5 * cp.quad_form(u, cp.psd_wrap(H1)) + h1 @ u), cons)
    prob.solve(solver=solver)
    if prob.status not in ("optimal", "optimal_inaccurate"):
        raise ValueError(f"the multi-distractor QP is {prob.status} for etas={etas.tolist()}")
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
    xs, us = [np.asarray(x0, float)], []
    for start in range(0, N, every):
        rest = N - start
        plan_x, plan_u, _ = multi_distractor_qp(
            dynamics.stages(start, rest), J1.stages(start, rest), [J.stages(start, rest) for J in distractors],
            xs[-1], rest, eta_of_s(start / N), solver=solver)
        steps = min(every, rest)
        us.extend(plan_u[:steps])
        xs.extend(plan_x[1:steps + 1])
    return np.array(xs), np.array(us)
