"""Property-based tests (hypothesis) of chapter 6's core invariants on random small problems: the Riccati
recursion (both backends) against one dense KKT solve, and the legible optimum of (1 + alpha) J1 - J0
against Theorem 6.4.2's likelihood-ratio minimiser (from the Gaussians)."""

import numpy as np
from hypothesis import given, settings, strategies as st

from mutual.motion.legible import legible_trajectory
from mutual.motion.legible.lqr import lq_cost, solve_lq
from mutual.motion.observer import likelihood_ratio_minimiser, log_likelihood_ratio


from helpers.lq import control_hessian, kkt_solve, random_hypotheses, random_problem

SETTINGS = settings(max_examples=30, deadline=None, derandomize=True)


def solve(p, backend="numpy"):
    return solve_lq(p["A"], p["B"], p["Q"], p["R"], p["x0"], p["N"], q=p["q"], r=p["r"], QN=p["QN"], qN=p["qN"],
                    M=p["M"], c=p["c"], backend=backend)


@SETTINGS
@given(seed=st.integers(0, 2 ** 31 - 1), n=st.integers(1, 4), m=st.integers(1, 3), N=st.integers(1, 12),
       convex_state=st.booleans())
def test_riccati_equals_dense_kkt(seed, n, m, N, convex_state):
    p = random_problem(seed, n=n, m=m, N=N, convex_state=convex_state, q_scale=0.01)
    try:
        sol = solve(p)
    except ValueError:   # an indefinite state cost may make it unbounded: then so says the dense Hessian
        assert np.linalg.eigvalsh(control_hessian(p))[0] <= 1e-6
        return
    xs, us = kkt_solve(p)
    scale = 1.0 + np.abs(us).max()
    np.testing.assert_allclose(sol.us, us, atol=1e-7 * scale)
    np.testing.assert_allclose(sol.xs, xs, atol=1e-7 * (1.0 + np.abs(xs).max()))
    cost = lq_cost(xs, us, p["Q"], p["R"], p["q"], p["r"], p["QN"], p["qN"], p["M"])
    assert abs(sol.cost - cost) <= 1e-7 * (1.0 + abs(cost))


@settings(max_examples=15, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2 ** 31 - 1), N=st.integers(1, 16))
def test_compiled_riccati_equals_dense_kkt(seed, N):
    """The compiled backend (one compile: n = 3, m = 2, horizons padded to 16) against the KKT solve."""
    p = random_problem(seed, n=3, m=2, N=N, convex_state=True)
    xs, us = kkt_solve(p)
    sol = solve(p, backend="jax")
    np.testing.assert_allclose(sol.us, us, atol=1e-8 * (1.0 + np.abs(us).max()))
    np.testing.assert_allclose(sol.xs, xs, atol=1e-8 * (1.0 + np.abs(xs).max()))


@SETTINGS
@given(seed=st.integers(0, 2 ** 31 - 1), n=st.integers(1, 3), m=st.integers(1, 3), N=st.integers(1, 10),
       alpha=st.floats(0.0, 3.0))
def test_legible_optimum_is_the_likelihood_ratio_minimiser(seed, n, m, N, alpha):
    """Theorem 6.4.2 with eq. (6.15): the Riccati minimiser of (1 + alpha) J1 - J0 equals the minimiser
    of log Lambda + alpha J1 computed from the two Gaussians' means and precisions, and no nearby
    control has a smaller log Lambda + alpha J1."""
    dyn, J0, J1, x0, N = random_hypotheses(seed, n=n, m=m, N=N)
    u_lambda = likelihood_ratio_minimiser(dyn, J0, J1, x0, N, alpha=alpha)
    sol = legible_trajectory(dyn, J1, J0, x0, N, alpha)
    scale = 1.0 + np.abs(u_lambda).max()
    np.testing.assert_allclose(sol.us, u_lambda, atol=1e-7 * scale)
    best = log_likelihood_ratio(dyn, J0, J1, x0, sol.us) + alpha * J1.value(sol.xs, sol.us)
    rng = np.random.default_rng(seed)
    for _ in range(3):
        u = sol.us + 1e-3 * scale * rng.normal(size=sol.us.shape)
        xs = _rollout(dyn, x0, u)
        assert log_likelihood_ratio(dyn, J0, J1, x0, u) + alpha * J1.value(xs, u) >= best - 1e-9 * (1 + abs(best))


def _rollout(dyn, x0, us):
    xs = [np.asarray(x0, float)]
    for u in us:
        xs.append(dyn.A @ xs[-1] + dyn.B @ u)
    return np.array(xs)
