"""Figure 7.2's legible objective by our iLQR against CasADi + IPOPT.

The problem (:mod:`mutual.motion.evident.safety`): the Dubins car of eq. (7.5) integrated exactly
over each step (:func:`mutual.motion.evident.vehicles.dubins_step`), N = 100 steps of dt = 0.025 s,
from ``figure_scenario("7.2")``'s start, and the legible objective ``(1 + alpha) J1 - J0`` of eq.
(6.15) with alpha = ``LEGIBLE_ALPHA``::

    J = a1 |P x_N - g|^2 + dt sum_k (a2 u_k^2 - a3 |P x_k - h|^2)

written again in CasADi symbolics (``sin(a)/a`` as a Taylor polynomial below |a| < 1e-3, where its
error is under 1e-21) and solved as a practitioner would: ``casadi.Opti`` with direct multiple
shooting (states and controls as decision variables, the dynamics as equality constraints), IPOPT
with its exact Hessian (the default), ``expand=True`` (SX evaluation), started from our start: zero
controls and their rollout. IPOPT's tolerance is tightened to 1e-10 so that both reach the same
cost. Ours: :func:`mutual.motion.evident.safety.solve` with its defaults. Times per solve are the
median of interleaved calls after a warm-up; CasADi's one-off set-up (building the symbolic problem
and IPOPT's first call) and our compile time are reported apart.
"""

import sys
from pathlib import Path

import casadi as ca
import numpy as np

from mutual.motion.evident import safety as es

sys.path.insert(0, str(Path(__file__).parent))
from peer_timing import interleaved, timed  # noqa: E402

AGREE = 1e-8  # relative agreement of the two optimal costs
IPOPT_TOL = 1e-10
SMALL_TURN = 1e-3  # below this half-turn, sin(a)/a by its Taylor polynomial


def sin_ratio(a):
    """``sin(a)/a``, smooth through 0 (both branches finite, so no NaN reaches a derivative)."""
    small = ca.fabs(a) < SMALL_TURN
    safe = ca.if_else(small, 1.0, a)
    a2 = a * a
    return ca.if_else(small, 1 - a2 / 6 * (1 - a2 / 20 * (1 - a2 / 42)), ca.sin(safe) / safe)


def dubins_function(dt, speed):
    """The exact-arc Dubins step of :func:`mutual.motion.evident.vehicles.dubins_step` as a CasADi Function."""
    x, u = ca.SX.sym("x", 3), ca.SX.sym("u", 1)
    turn = u[0] * dt
    chord = speed * dt * sin_ratio(turn / 2)
    mid = x[2] + turn / 2
    return ca.Function("dubins", [x, u], [ca.vertcat(x[0] + chord * ca.cos(mid), x[1] + chord * ca.sin(mid),
                                                     x[2] + turn)])


def legible_opti(task, weights, xs0, us0):
    """``(opti, X, U, J)``: the problem in CasADi's Opti, started at ``(xs0, us0)``."""
    a_goal, a_effort, a_hazard, _ = (float(w) for w in weights)
    N, dt = task.steps, task.dt
    f = dubins_function(dt, task.speed)
    opti = ca.Opti()
    X, U = opti.variable(3, N + 1), opti.variable(1, N)
    opti.subject_to(X[:, 0] == task.x0)
    for k in range(N):
        opti.subject_to(X[:, k + 1] == f(X[:, k], U[:, k]))
    P, g, h = X[:2, :], task.goal, task.hazard
    running = sum(dt * (a_effort * U[0, k] ** 2 - a_hazard * ca.sumsqr(P[:, k] - h)) for k in range(N))
    J = a_goal * ca.sumsqr(P[:, N] - g) + running
    opti.minimize(J)
    opti.set_initial(X, xs0.T)
    opti.set_initial(U, us0.T)
    opti.solver("ipopt", {"expand": True, "print_time": False},
                {"print_level": 0, "sb": "yes", "tol": IPOPT_TOL, "hessian_approximation": "exact"})
    return opti, X, U, J


def run(quick=False):
    task, w0, w1 = es.figure_scenario("7.2")
    weights = es.legible_weights(w1, w0, es.LEGIBLE_ALPHA)
    us0 = task.zero_controls()
    xs0 = es.rollout(task, us0)

    def ours():
        return es.solve(task, weights)

    first, _ = timed(ours)
    setup, (opti, X, U, J) = timed(lambda: legible_opti(task, weights, xs0, us0))
    first_ipopt, _ = timed(opti.solve)

    def ipopt():
        return opti.solve()

    (t_ours, t_ipopt), (r, sol) = interleaved([ours, ipopt], 10 if quick else 50)
    stats = sol.stats()
    evaluations = sum(v for k, v in stats.items() if k.startswith("t_wall_nlp_"))  # CasADi's own function calls
    us, xs = np.asarray(sol.value(U)).reshape(-1, 1), np.asarray(sol.value(X)).T
    reported = float(sol.value(J))
    shooting = es.cost(task, weights, us)  # IPOPT's controls through our rollout and cost
    gap = abs(r.cost - reported) / abs(reported)
    defect = float(np.max(np.abs(es.rollout(task, us) - xs)))
    agree = bool(stats["success"] and gap <= AGREE and abs(shooting - reported) <= AGREE * abs(reported))
    ratio = t_ipopt["median"] / t_ours["median"]
    return [{
        "benchmark": "peers: CasADi + IPOPT",
        "case": (f"Fig. 7.2 legible objective (1 + {es.LEGIBLE_ALPHA:g}) J1 - J0, Dubins car with exact arcs, N={task.steps}: "
                 f"iLQR {r.iterations} it / {r.passes} passes, IPOPT {stats['iter_count']} it "
                 f"({stats['return_status']}, tol {IPOPT_TOL:g}; {evaluations * 1e3:.3g} ms of its last solve in "
                 "CasADi's function evaluations)"),
        "seconds": t_ours["median"],
        "baseline": (f"CasADi {ca.__version__} Opti + IPOPT (exact Hessian, MUMPS, expand=True), multiple shooting, "
                     "same start"),
        "baseline_seconds": t_ipopt["median"], "compile_seconds": first - t_ours["median"],
        "agree": (f"{agree}: costs {r.cost:.12g} (ours) / {reported:.12g} (IPOPT), relative gap {gap:.1e} (target "
                  f"{AGREE:g}); IPOPT's controls through our rollout cost {shooting:.12g}, its states off our rollout "
                  f"by {defect:.1e}; max |du| {np.max(np.abs(r.us - us)):.1e}; CasADi set-up {setup:.2f} s + first "
                  f"solve {first_ipopt:.3f} s; medians of {t_ours['runs']} interleaved solves, ours "
                  f"{t_ours['min'] * 1e3:.3g}-{t_ours['max'] * 1e3:.3g} ms, IPOPT "
                  f"{t_ipopt['min'] * 1e3:.3g}-{t_ipopt['max'] * 1e3:.3g} ms"),
        "target": ">= 10x CasADi + IPOPT per solve, costs to 1e-8", "met": bool(agree and ratio >= 10)}]


if __name__ == "__main__":
    for row in run(quick=True):
        print(row)
