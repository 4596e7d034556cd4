"""Chapter 6's statements checked by routes that share no code with the Riccati solver they check.

* :func:`lemma_641_exhaustive` -- Lemma 6.4.1 with Theorem 6.4.2's control, on a small *discrete*
  problem where every control sequence can be listed: the partition functions ``Z_i`` of eq. (6.9)
  are exact sums, so every rejection region ``{u : Lambda(u) <= eta}`` (eq. (6.11)) is an explicit
  set; the robot's control is the minimiser of ``J1 - J0`` found by dynamic programming (eq. 6.13).
* :func:`lbfgs_likelihood_ratio_minimiser` -- Theorem 6.4.2: scipy's L-BFGS on the *raw* objective
  ``log Lambda(u) = log P(u | H0) - log P(u | H1)`` of eqs. (6.7)-(6.9), partition functions
  included, each cost rolled out step by step.
* :func:`multi_distractor_kkt` -- section 6.5's Lagrangian: the multi-distractor QP by a conic solver and
  an active set, its KKT conditions checked by hand, against the Riccati LQR of the linear combination.
* :func:`bounded_legible_qp` -- Theorem 6.4.2 under a running control bound (line 1356), against L-BFGS-B
  on the raw ratio (:func:`lbfgs_likelihood_ratio_minimiser` with ``bound``).
* :func:`suboptimality_multiplier` -- section 6.4's reading of ``alpha`` (line 1232) as the
  Lagrange multiplier of a sub-optimality bound: ``min J1 - J0 s.t. J1 <= J1* + eps`` posed in
  states and controls and solved by a generic conic solver (cvxpy with Clarabel), whose multiplier
  is then compared with the ``alpha`` of eq. (6.15).
"""

import itertools
import warnings

import cvxpy as cp
import jax
import jax.numpy as jnp
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.optimize import minimize
from scipy.special import logsumexp

from .objective import legible_trajectory
from .problem import check_lq_problem, solve
from .qp import affine_constraints, dynamics_constraints, multi_distractor_qp, stacked_cost


# ---- Lemma 6.4.1 on a problem small enough to list every control sequence ---------------------------

def random_discrete_hypotheses(rng, T=8, span=4):
    """Two random hypotheses about a walker on the integers, ``x_{t+1} = x_t + u_t``, ``u_t in {-1, 0, 1}``,
    ``x_0 = 0``, over ``T`` steps. Hypothesis ``i`` costs ``a_i (x_T - g_i)^2 + b_i sum_t u_t^2 +
    c_i sum_t (x_t - h_i)^2`` (a reach with a running preference, either sign), drawn at random with goals
    and points in ``[-span, span]``. Returns a list of two dicts with keys ``a, b, c, g, h``."""
    return [{"a": rng.uniform(0.2, 1.0), "b": rng.uniform(0.1, 1.0), "c": rng.uniform(-0.1, 0.1),
             "g": float(rng.integers(-span, span + 1)), "h": float(rng.integers(-span, span + 1))}
            for _ in range(2)]


def _discrete_cost(hyp, x, u, terminal=True):
    """The hypothesis's cost of stage controls ``u`` from positions ``x`` (stage) or of the end ``x`` (terminal)."""
    if terminal:
        return hyp["a"] * (x - hyp["g"]) ** 2
    return hyp["b"] * u ** 2 + hyp["c"] * (x - hyp["h"]) ** 2


def discrete_legible_controls(hypotheses, T):
    """The minimiser of ``J1 - J0`` (eq. (6.13)) for :func:`random_discrete_hypotheses`, by backward dynamic
    programming over the positions ``-T .. T`` (ties go to the smaller control). Returns ``(controls (T,), value)``."""
    h0, h1 = hypotheses
    positions = np.arange(-T, T + 1, dtype=float)
    actions = np.array([-1.0, 0.0, 1.0])
    value = _discrete_cost(h1, positions, None) - _discrete_cost(h0, positions, None)
    choice = np.zeros((T, positions.size), dtype=int)
    for t in reversed(range(T)):
        nxt = np.clip(np.arange(positions.size)[:, None] + actions[None, :].astype(int), 0, positions.size - 1)
        stage = (_discrete_cost(h1, positions[:, None], actions[None, :], terminal=False)
                 - _discrete_cost(h0, positions[:, None], actions[None, :], terminal=False))
        q = stage + value[nxt]
        choice[t] = np.argmin(q, axis=1)
        value = q[np.arange(positions.size), choice[t]]
    x, us = T, []                              # index of position 0
    for t in range(T):
        a = choice[t, x]
        us.append(actions[a])
        x += int(actions[a])
    return np.array(us), float(value[T])


def _all_sequences(T):
    us = np.array(list(itertools.product((-1.0, 0.0, 1.0), repeat=T)))
    xs = np.concatenate([np.zeros((len(us), 1)), np.cumsum(us, axis=1)], axis=1)
    return us, xs


def _sequence_costs(hyp, us, xs):
    stage = _discrete_cost(hyp, xs[:, :-1], us, terminal=False).sum(axis=1)
    return stage + _discrete_cost(hyp, xs[:, -1], None)


def exact_log_probabilities(hypotheses, T=8):
    """``log P(u | H_i)`` (eqs. (6.8)-(6.9), partition functions as exact sums) of every one of the ``3^T``
    control sequences of :func:`random_discrete_hypotheses`: an array (len(hypotheses), 3^T)."""
    if not isinstance(T, (int, np.integer)) or not 1 <= T <= 10:
        raise ValueError(f"T must be an integer from 1 to 10 (3^T sequences are listed), got {T!r}")
    us, xs = _all_sequences(T)
    costs = np.array([_sequence_costs(h, us, xs) for h in hypotheses])
    return -costs - logsumexp(-costs, axis=1, keepdims=True)


def lemma_641_exhaustive(hypotheses, T=8):
    """Lemma 6.4.1 for the robot that minimises ``J1 - J0`` (Theorem 6.4.2), checked on every one of the
    ``3^T`` control sequences of :func:`random_discrete_hypotheses`.

    ``log Lambda(u) = -J0(u) - log Z0 + J1(u) + log Z1`` with ``Z_i`` the exact sums of eq. (6.9). The
    rejection region ``R(eta) = {u : Lambda(u) <= eta}`` changes only at the values ``Lambda`` takes, so the
    lemma holds when the robot's control lies in ``R(eta)`` for each of those ``eta`` (every non-empty
    region), i.e. when no sequence has a smaller ``Lambda``. Returns a dict: ``holds``, ``regions`` (the
    number of distinct non-empty regions), ``sequences``, ``log_lambda_robot``, ``log_lambda_min`` and
    ``outside`` (how many regions miss the robot's control)."""
    if not isinstance(T, (int, np.integer)) or not 1 <= T <= 10:
        raise ValueError(f"T must be an integer from 1 to 10 (3^T sequences are listed), got {T!r}")
    us, xs = _all_sequences(T)
    j0, j1 = (_sequence_costs(h, us, xs) for h in hypotheses)
    log_lambda = (-j0 - logsumexp(-j0)) - (-j1 - logsumexp(-j1))
    robot, _ = discrete_legible_controls(hypotheses, T)
    index = int(np.flatnonzero(np.all(us == robot, axis=1))[0])
    etas = np.unique(np.round(log_lambda, 12))
    mine = log_lambda[index]
    outside = int(np.sum(mine > etas + 1e-12 * max(1.0, np.abs(etas).max())))
    return {"holds": outside == 0, "regions": int(etas.size), "sequences": int(len(us)),
            "log_lambda_robot": float(mine), "log_lambda_min": float(log_lambda.min()), "outside": outside}


# ---- Theorem 6.4.2 by a generic optimiser on the raw likelihood ratio --------------------------------

def _stage_arrays(dynamics, cost, N):
    dyn, c = dynamics.stages(0, N), cost.stages(0, N)
    n, m = dyn.n, dyn.m
    return {"A": np.broadcast_to(dyn.A, (N, n, n)), "B": np.broadcast_to(dyn.B, (N, n, m)),
            "Q": np.broadcast_to(c.Q, (N, n, n)), "q": np.broadcast_to(c.q, (N, n)),
            "R": np.broadcast_to(c.R, (N, m, m)), "r": np.broadcast_to(c.r, (N, m)),
            "QN": c.QN, "qN": c.qN, "const": np.float64(c.const)}


def _rolled_out_cost(flat, x0, arrays):
    """``J(u)``: the state rolled out step by step and each stage's cost added (eq. (6.6))."""
    us = flat.reshape(arrays["B"].shape[0], arrays["B"].shape[-1])

    def stage(carry, s):
        x, total = carry
        u = us[s["k"]]
        total = total + 0.5 * x @ s["Q"] @ x + s["q"] @ x + 0.5 * u @ s["R"] @ u + s["r"] @ u
        return (s["A"] @ x + s["B"] @ u, total), None

    per_stage = {f: arrays[f] for f in ("A", "B", "Q", "q", "R", "r")}
    per_stage["k"] = jnp.arange(us.shape[0])
    (x, total), _ = jax.lax.scan(stage, (x0, arrays["const"]), per_stage)
    return total + 0.5 * x @ arrays["QN"] @ x + arrays["qN"] @ x


def _raw_log_ratio(flat, x0, arrays0, arrays1, log_z0, log_z1, alpha):
    j0, j1 = _rolled_out_cost(flat, x0, arrays0), _rolled_out_cost(flat, x0, arrays1)
    return (-j0 - log_z0) - (-j1 - log_z1) + alpha * j1


_RAW_VALUE_AND_GRAD = jax.jit(jax.value_and_grad(_raw_log_ratio))
_COST_GRAD_HESSIAN = jax.jit(lambda flat, x0, arrays: (_rolled_out_cost(flat, x0, arrays),
                                                      jax.grad(_rolled_out_cost)(flat, x0, arrays),
                                                      jax.hessian(_rolled_out_cost)(flat, x0, arrays)))


def log_partition(x0, arrays):
    """``log Z = log int exp(-J(u)) du`` (eq. (6.9)) of a hypothesis whose rolled-out cost is a strictly
    convex quadratic in the controls: ``-J(u*) + d/2 log 2 pi - 1/2 log det H`` with the curvature ``H``
    and the minimiser ``u*`` from automatic differentiation of the rolled-out cost."""
    size = arrays["B"].shape[0] * arrays["B"].shape[-1]
    value, grad, H = (np.asarray(a) for a in _COST_GRAD_HESSIAN(jnp.zeros(size), x0, arrays))
    H = 0.5 * (H + H.T)
    sign, logdet = np.linalg.slogdet(H)
    if sign <= 0 or np.linalg.eigvalsh(H)[0] <= 0:
        raise ValueError("a hypothesis's cost is not strictly convex in the controls: its Z is infinite")
    step = np.linalg.solve(H, -grad)
    return float(-(value + grad @ step + 0.5 * step @ H @ step) + 0.5 * size * np.log(2 * np.pi) - 0.5 * logdet)


def lbfgs_likelihood_ratio_minimiser(dynamics, J0, J1, x0, N, alpha=0.0, gtol=1e-11, bound=None):
    """Theorem 6.4.2 by a generic optimiser: L-BFGS (scipy) on the raw ``log Lambda(u) + alpha J1(u)``,
    ``log Lambda = log P(u|H0) - log P(u|H1)`` with ``log P(u|H_i) = -J_i(u) - log Z_i`` (eqs. (6.7)-(6.9)):
    each cost rolled out step by step (:func:`_rolled_out_cost`), each partition function from
    :func:`log_partition`, gradients by automatic differentiation, from zero controls. ``bound``: a running
    constraint ``|u_k,j| <= bound`` on every control (L-BFGS-B's box; the partition functions stay
    constants, so Theorem 6.4.2's argument is unchanged). Returns ``(controls (N, m), scipy result)``."""
    for cost in (J0, J1):
        check_lq_problem(dynamics, cost, N)
    if not (np.isfinite(alpha) and alpha >= 0):
        raise ValueError(f"alpha must be a finite number >= 0, got {alpha!r}")
    if bound is not None and not (np.isfinite(bound) and bound > 0):
        raise ValueError(f"bound must be a positive finite number (|u| <= bound) or None, got {bound!r}")
    with jax.enable_x64(True):
        x0 = jnp.asarray(x0, float)
        arrays0, arrays1 = _stage_arrays(dynamics, J0, N), _stage_arrays(dynamics, J1, N)
        log_z0, log_z1 = log_partition(x0, arrays0), log_partition(x0, arrays1)

        def fun(flat):
            v, g = _RAW_VALUE_AND_GRAD(jnp.asarray(flat), x0, arrays0, arrays1, log_z0, log_z1, alpha)
            return float(v), np.asarray(g, float)
        box = None if bound is None else [(-bound, bound)] * (N * dynamics.m)
        result = minimize(fun, np.zeros(N * dynamics.m), jac=True, method="L-BFGS-B", bounds=box,
                          options={"gtol": gtol, "ftol": 1e-16, "maxiter": 20_000, "maxcor": 30})
    return result.x.reshape(N, dynamics.m), result


def bounded_legible_qp(dynamics, J1, J0, x0, N, alpha, bound, solver="CLARABEL"):
    """``min (1 + alpha) J1 - J0`` subject to the dynamics and the running constraint ``|u_k,j| <= bound``, by
    a conic solver (cvxpy, states and controls as variables; no Riccati recursion, no likelihoods). Returns
    ``(controls (N, m), number of controls at the bound)``."""
    for cost in (J0, J1):
        check_lq_problem(dynamics, cost, N)
    n, m = dynamics.n, dynamics.m
    E, e = dynamics_constraints(dynamics, np.asarray(x0, float), N)
    z = cp.Variable(E.shape[1])
    objective = _convex_quadratic(*stacked_cost((1 + alpha) * J1 - J0, N, n, m), z, "(1 + alpha) J1 - J0")
    u = z[(N + 1) * n:]
    prob = cp.Problem(cp.Minimize(objective), [E @ z == e, u <= bound, -u <= bound])
    prob.solve(solver=solver, **(TIGHT if solver == "CLARABEL" else {}))
    if prob.status != "optimal":
        raise ValueError(f"the bounded legible problem is {prob.status}")
    us = np.asarray(u.value).reshape(N, m)
    return us, int(np.sum(np.abs(us) >= bound * (1 - 1e-7)))


# ---- section 6.5's Lagrangian: the multi-distractor QP by three routes -------------------------------

def multi_distractor_kkt(dynamics, J1, distractors, x0, N, etas):
    """Section 6.5 (line 1280): the QP ``min J1 s.t. J1 - J0_i <= eta_i`` reduces to the linear combination
    ``(1 + sum l) J1 - sum l_i J0_i`` with its multipliers ``l``. The QP is solved by Clarabel (cvxpy, at the
    tolerances of :data:`TIGHT`: its multipliers are compared, not only its controls) and by
    the active set of :mod:`.qp` (no cvxpy); the KKT conditions are checked by hand on Clarabel's answer
    (stationarity with the dynamics' multipliers fitted by least squares, primal and dual feasibility,
    complementary slackness); then the Riccati LQR of the combination, with either solver's multipliers
    (they differ when more bounds bind than the end point has dimensions), is compared with the QP's
    solution. Returns a dict of relative gaps and residuals, the multipliers, how many are positive and how
    many bounds are active."""
    distractors = list(distractors)
    xs, us, lam = multi_distractor_qp(dynamics, J1, distractors, x0, N, etas, solver_options=TIGHT)
    lam = np.clip(lam, 0.0, None)                 # the interior point's -1e-12 are zeros
    _, us_b, lam_b = multi_distractor_qp(dynamics, J1, distractors, x0, N, etas, solver="active-set")
    n, m = dynamics.n, dynamics.m
    E, e = dynamics_constraints(dynamics, np.asarray(x0, float), N)
    P, p, _ = stacked_cost(J1, N, n, m)
    A, c = affine_constraints(dynamics, J1, distractors, N)
    z = np.concatenate([xs.ravel(), us.ravel()])
    grad = P @ z + p + A.T @ lam
    nu = spla.lsqr(E.T, -grad, atol=1e-14, btol=1e-14)[0]
    g = A @ z + c - np.broadcast_to(etas, lam.shape)
    scale_u, scale_l, scale_g = np.abs(us).max(), max(1e-12, np.abs(lam).max()), max(1.0, np.abs(etas).max())

    def lagrangian(weights):                      # the Riccati LQR of (1 + sum l) J1 - sum l_i J0_i
        sol = legible_trajectory(dynamics, J1, distractors, x0, N, weights.sum(), weights=weights) \
            if weights.sum() > 0 else solve(dynamics, J1, x0, N)
        return float(np.abs(sol.us - us).max() / scale_u)
    return {"multipliers": lam, "positive": int(np.sum(lam > 1e-6 * scale_l)),
            "active": int(np.sum(np.abs(g) <= 1e-7 * scale_g)),
            "solvers u": float(np.abs(us - us_b).max() / scale_u),
            "solvers multipliers": float(np.abs(lam - lam_b).max() / scale_l),
            "stationarity": float(np.linalg.norm(grad + E.T @ nu) / max(1.0, np.linalg.norm(p))),
            "feasibility": float(max(g.max(), np.abs(E @ z - e).max()) / scale_g),
            "complementarity": float(np.abs(lam * g).max() / (scale_g * scale_l)),
            "Lagrangian (Riccati) u": lagrangian(lam), "Lagrangian, active-set multipliers": lagrangian(lam_b)}


# ---- alpha as the multiplier of a sub-optimality bound (line 1232) ------------------------------------

def _convex_quadratic(P, p, const, z, name):
    P = sp.csc_matrix(P)
    if P.nnz == 0 or abs(P).max() == 0:
        return p @ z + const
    if np.linalg.eigvalsh(P.toarray())[0] < -1e-9 * abs(P).max():
        raise ValueError(f"{name} is not convex in the states and controls")
    return 0.5 * cp.quad_form(z, cp.psd_wrap(P)) + p @ z + const


TIGHT = {"tol_gap_abs": 1e-12, "tol_gap_rel": 1e-12, "tol_feas": 1e-12, "tol_ktratio": 1e-10}  # Clarabel


def suboptimality_multiplier(dynamics, J1, J0, x0, N, epsilon, solver="CLARABEL", **solver_options):
    """Section 6.4 (line 1232): ``alpha`` as the Lagrange multiplier of a bound on the task's sub-optimality.

    Solves ``J1* = min J1``, then ``min J1 - J0 s.t. J1 <= J1* + epsilon`` with cvxpy, the states and
    controls as variables and the dynamics as sparse equality constraints (a conic solver: no Riccati
    recursion, no lifted costs). The Lagrangian is ``(1 + lam) J1 - J0 + const``, so the thesis's reading
    says the bounded optimum is the optimum of eq. (6.15) at ``alpha = lam``. ``J1 - J0`` must be convex
    (affine for eq. (6.17)). Returns a dict: ``us`` (N, m), ``multiplier`` lam, ``J1_star`` and ``J1`` at
    the bounded optimum (``J1* + epsilon`` when the bound binds) and the solver's ``status``. Clarabel runs with tolerances of 1e-12
    (:data:`TIGHT`) unless ``solver_options`` are given."""
    for cost in (J0, J1):
        check_lq_problem(dynamics, cost, N)
    if not (np.isfinite(epsilon) and epsilon > 0):
        raise ValueError(f"epsilon must be a positive finite number, got {epsilon!r}")
    n, m = dynamics.n, dynamics.m
    E, e = dynamics_constraints(dynamics, np.asarray(x0, float), N)
    z = cp.Variable(E.shape[1])
    j1 = _convex_quadratic(*stacked_cost(J1, N, n, m), z, "J1")
    difference = _convex_quadratic(*stacked_cost(J1 - J0, N, n, m), z, "J1 - J0")
    best = cp.Problem(cp.Minimize(j1), [E @ z == e])
    options = TIGHT if (solver == "CLARABEL" and not solver_options) else solver_options
    best.solve(solver=solver, **options)
    j1_star = float(best.value)
    bound = j1 <= j1_star + epsilon
    prob = cp.Problem(cp.Minimize(difference), [E @ z == e, bound])
    with warnings.catch_warnings():          # "optimal_inaccurate" at 1e-12 tolerances is kept and reported
        warnings.simplefilter("ignore", UserWarning)
        prob.solve(solver=solver, **options)
    if prob.status not in ("optimal", "optimal_inaccurate"):
        raise ValueError(f"the bounded problem is {prob.status} for epsilon = {epsilon!r}")
    return {"us": np.asarray(z.value[(N + 1) * n:]).reshape(N, m), "multiplier": float(np.ravel(bound.dual_value)[0]),
            "J1_star": j1_star, "J1": float(j1.value), "status": prob.status}
