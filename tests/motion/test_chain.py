"""The observer's banded (Riccati) factorisation against the dense form it replaced. The dense reference lives
here only, as the independent route: the lifted Hessian of all stages (``observer.lifted_cost``, no Riccati
recursion) with dense Cholesky factors and solves, and for the Laplace belief the Hessian of the whole
objective by autodiff; the banded forms serve long horizons the dense matrix cannot."""

from fractions import Fraction

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mutual.motion import belief, legible as leg, observer
from mutual.motion.chain import ChainGaussian, log_ratio_prefix, lq_chains
from mutual.motion.evident import safety as es
from mutual.motion.legible import random_lq_hypotheses
from mutual.motion.trajopt.compiled import kernels


TOL = 1e-9
PROBLEMS = [(0, 2, 2, 10), (1, 3, 1, 7), (2, 1, 2, 15), (3, 4, 3, 5), (4, 2, 2, 1), (5, 2, 1, 40)]


def close(banded, dense, tol=TOL):
    banded, dense = np.asarray(banded, float), np.asarray(dense, float)
    assert banded.shape == dense.shape
    gap = np.abs(banded - dense) / np.maximum(1.0, np.abs(dense))
    assert gap.max(initial=0.0) <= tol, f"largest relative gap {gap.max():.3g}"


def close_matrix(banded, dense, tol=TOL):
    assert np.abs(np.asarray(banded) - dense).max() <= tol * np.abs(dense).max()


def dense_gaussian(dyn, cost, x0, N):
    """``(mean, H, log Z)`` of exp(-J) over the stacked controls, from the lifted form."""
    H, h, c = observer.lifted_cost(dyn, cost, x0, N)
    L = np.linalg.cholesky(H)
    mean = -np.linalg.solve(H, h)
    log_z = -c - 0.5 * h @ mean + 0.5 * len(h) * np.log(2 * np.pi) - np.log(np.diag(L)).sum()
    return mean, H, log_z


def dense_prefix(us, mean, H):
    """``log N(u_{0:t})`` for t = 0..N from the covariance's Cholesky factor."""
    N = len(us)
    L = np.linalg.cholesky(np.linalg.inv(H))
    z = np.linalg.solve(L, us.reshape(-1) - mean.reshape(-1))
    terms = -0.5 * z ** 2 - np.log(np.diag(L)) - 0.5 * np.log(2 * np.pi)
    return np.concatenate([[0.0], np.cumsum(terms.reshape(N, -1).sum(axis=1))])


def dense_trailing(H):
    L = np.linalg.cholesky(H[::-1, ::-1])
    return np.concatenate([[0.0], np.cumsum(2 * np.log(np.diag(L)))])[::-1]


def extended_prefix(dyn, cost, x0, us):
    """:func:`dense_prefix` in x87 extended precision (``np.longdouble``, eps 1.1e-19), from the lifted form
    built in that precision: a reference for problems too ill-conditioned for the float64 dense form."""
    ld = np.longdouble
    N, m = us.shape
    d, c = dyn.stages(0, N), cost.stages(0, N)
    n = d.n
    stage = [np.broadcast_to(a, (N, *np.shape(a)[-k:])).astype(ld) for a, k in
             ((d.A, 2), (d.B, 2), (c.Q, 2), (c.q, 1), (c.R, 2), (c.r, 1))]
    Fx, fx = np.zeros((n, N * m), ld), np.asarray(x0).astype(ld)
    H, h = np.zeros((N * m, N * m), ld), np.zeros(N * m, ld)
    for k in range(N + 1):
        Q, q = (stage[2][k], stage[3][k]) if k < N else (np.asarray(c.QN).astype(ld), np.asarray(c.qN).astype(ld))
        H, h = H + Fx.T @ Q @ Fx, h + Fx.T @ (Q @ fx + q)
        if k < N:
            A, B, R, r = stage[0][k], stage[1][k], stage[4][k], stage[5][k]
            H[k * m:(k + 1) * m, k * m:(k + 1) * m] += R
            h[k * m:(k + 1) * m] += r
            Fx, fx = A @ Fx, A @ fx
            Fx[:, k * m:(k + 1) * m] += B

    def cholesky(S):
        L = np.zeros_like(S)
        for j in range(len(S)):
            L[j, j] = np.sqrt(S[j, j] - L[j, :j] @ L[j, :j])
            L[j + 1:, j] = (S[j + 1:, j] - L[j + 1:, :j] @ L[j, :j]) / L[j, j]
        return L

    H = 0.5 * (H + H.T)
    U = cholesky(H[::-1, ::-1])[::-1, ::-1]              # H = U U', U upper
    z = np.zeros(N * m, ld)                               # w = U'(u - mean) = U'u + U^-1 h
    for i in reversed(range(N * m)):
        z[i] = (h[i] - U[i, i + 1:] @ z[i + 1:]) / U[i, i]
    w = U.T @ us.reshape(-1).astype(ld) + z
    terms = -0.5 * w ** 2 - 0.5 * np.log(ld(2) * np.pi) + np.log(np.diag(U))
    return np.concatenate([[0.0], np.cumsum(terms.reshape(N, m).sum(axis=1))])


def problem(seed, n, m, N):
    rng = np.random.default_rng(seed)
    dyn, J0, J1, x0 = random_lq_hypotheses(rng, n, m, N)
    return dyn, J0, J1, x0, 2.0 * rng.normal(size=(N, m)), rng.uniform(size=N)


@pytest.mark.parametrize("seed, n, m, N", PROBLEMS)
def test_observer_equals_the_dense_form(seed, n, m, N):
    dyn, J0, J1, x0, us, w = problem(seed, n, m, N)
    (mu0, H0, z0), (mu1, H1, z1) = (dense_gaussian(dyn, J, x0, N) for J in (J0, J1))
    u = us.reshape(-1)
    lb0 = -(0.5 * u @ H0 @ u + (-H0 @ mu0) @ u + observer.lifted_cost(dyn, J0, x0, N)[2]) - z0
    close(observer.log_boltzmann(dyn, J0, x0, us), lb0)
    lb1 = dense_prefix(us, mu1, H1)[-1]
    close(observer.log_likelihood_ratio(dyn, J0, J1, x0, us), lb0 - lb1)
    close(observer.log_boltzmann_prefix(dyn, J0, x0, us), dense_prefix(us, mu0, H0))
    J2 = J0 + J1
    mu2, H2, _ = dense_gaussian(dyn, J2, x0, N)
    logs = np.stack([dense_prefix(us, mu, H) for mu, H in ((mu0, H0), (mu1, H1), (mu2, H2))], axis=1)
    post = np.exp(logs - logs.max(axis=1, keepdims=True))
    close(observer.posterior_over_time(dyn, [J0, J1, J2], x0, us), post / post.sum(axis=1, keepdims=True))


@pytest.mark.parametrize("seed, n, m, N", PROBLEMS)
def test_weighted_prefix_evidence_equals_the_dense_form(seed, n, m, N):
    """The quadratic of the time-weighted prefix evidence: the dense form ``U diag(F) U'`` with ``H = U U'``."""
    dyn, J0, _, x0, us, w = problem(seed, n, m, N)
    mean, H, _ = dense_gaussian(dyn, J0, x0, N)
    U = np.linalg.cholesky(H[::-1, ::-1])[::-1, ::-1]
    F = np.repeat(np.cumsum(w[::-1])[::-1], m)
    Hw = (U * F) @ U.T
    cw = 0.5 * mean @ Hw @ mean - np.sum(F * (np.log(np.diag(U)) - 0.5 * np.log(2 * np.pi)))
    got = observer.weighted_prefix_log_likelihood(dyn, J0, x0, N, w)
    close_matrix(got[0], Hw)
    close(got[1], -Hw @ mean)
    close(got[2], cw)


@pytest.mark.parametrize("seed, n, m, N", PROBLEMS)
def test_belief_gaussians_equal_the_dense_form(seed, n, m, N):
    dyn, J0, J1, x0, us, _ = problem(seed, n, m, N)
    g0, g1 = belief.lq_gaussian(dyn, J0, x0, N), belief.lq_gaussian(dyn, J1, x0, N)
    (mu0, H0, _), (mu1, H1, _) = (dense_gaussian(dyn, J, x0, N) for J in (J0, J1))
    assert isinstance(g0, ChainGaussian) and g0.mean.shape == (N, m)
    close(g0.mean.reshape(-1), mu0)
    close_matrix(g0.precision(), H0)
    mean, precision = g1                                   # unpacks as the dense pair
    close_matrix(precision, H1)
    close(belief.gaussian_prefix_loglik(us, g0), dense_prefix(us, mu0, H0))
    close(belief.gaussian_prefix_loglik(us, mu0.reshape(N, m), H0), dense_prefix(us, mu0, H0))
    close(belief.trailing_logdets(g0), dense_trailing(H0))
    close(g0.prefix_logdets(), dense_trailing(H0)[0] - dense_trailing(H0)[::m])
    logit = dense_prefix(us, mu1, H1) - dense_prefix(us, mu0, H0) + np.log(0.3 / 0.7)
    posterior = 0.5 * (1 + np.tanh(0.5 * logit))
    close(belief.posterior_over_time(us, g0, g1, prior=0.3), posterior)
    close(belief.posterior_over_time(us, (mu0.reshape(N, m), H0), g1, prior=0.3), posterior)


@pytest.mark.skipif(np.finfo(np.longdouble).eps > 1e-18, reason="needs x87 extended precision")
def test_banded_form_is_accurate_where_the_dense_form_is_not():
    """An unstable random problem (spectral radius 1.3, cond(H) ~ 4e5): the float64 dense form is off by
    ~1e-8 (relative) here, the banded form agrees with the extended-precision dense form to 1e-13."""
    dyn, J0, J1, x0, us, _ = problem(128, 3, 2, 23)
    p0, p1 = extended_prefix(dyn, J0, x0, us), extended_prefix(dyn, J1, x0, us)
    close(observer.log_boltzmann_prefix(dyn, J0, x0, us), p0.astype(float), tol=1e-13)
    close(observer.log_likelihood_ratio(dyn, J0, J1, x0, us), float(p0[-1] - p1[-1]), tol=1e-13)


def test_one_factorisation_serves_every_hypothesis():
    """lq_chains factors all the costs in one batched pass; each equals its own factorisation."""
    dyn, J0, J1, x0, us, _ = problem(7, 3, 2, 12)
    both = lq_chains(dyn, [J0, J1, J0], x0, 12)
    alone = lq_chains(dyn, [J1], x0, 12)[0]
    np.testing.assert_array_equal(both[1].K, alone.K)
    np.testing.assert_array_equal(both[1].L, alone.L)
    assert log_ratio_prefix(us, both[0], both[2])[-1] == 0.0


@pytest.fixture(scope="module")
def dubins():
    task, w0, w1 = es.figure_scenario("7.2", steps=20)
    return task, {name: (w, es.solve(task, w)) for name, w in (("H0", w0), ("H1", w1))}


def test_laplace_hessian_factors_through_the_ddp_backward_pass(dubins):
    """The DDP backward pass at the optimum (second derivatives of the dynamics weighted by the costates)
    factors exactly the autodiff Hessian of the single-shooting cost."""
    task, hypotheses = dubins
    rng = np.random.default_rng(0)
    for name, (w, optimum) in hypotheses.items():
        dyn, run, term, x0, params = es.problem(task, w)
        g = belief.laplace_gaussian(dyn, run, term, x0, optimum.us, params)
        with jax.enable_x64(True):
            H = np.asarray(kernels(dyn, run, term).hessian(jnp.asarray(optimum.us), jnp.asarray(x0), params))
        H = 0.5 * (H + H.T)
        close_matrix(g.precision(), H)
        us = optimum.us + 0.3 * rng.normal(size=optimum.us.shape)
        close(belief.gaussian_prefix_loglik(us, g), dense_prefix(us, optimum.us, H))
        close(belief.trailing_logdets(g), dense_trailing(H))
        np.testing.assert_array_equal(g.mean, optimum.us)


def test_laplace_refuses_a_point_that_is_not_a_strict_minimum():
    def step(x, u, p):
        return x + u

    def running(x, u, p):
        return -jnp.sum(u ** 2)                     # concave in the controls: no Laplace form

    def terminal(x, p):
        return jnp.sum(x ** 2)

    with pytest.raises(ValueError, match="not positive definite"):
        belief.laplace_gaussian(step, running, terminal, np.zeros(1), np.zeros((3, 1)), {})


G0, G1 = (-1.0, 1.0), (1.0, 1.0)
X0 = np.zeros(2)


def test_banded_forms_serve_a_long_horizon_and_refuse_its_dense_matrix():
    """12 000 steps: the observer's evidence for the goal's own optimal motion equals J1 - J0 exactly (the goals
    are symmetric about the start), while the dense precision (4.3 GiB) is refused."""
    n_steps = 12_000
    dyn = leg.single_integrator(2, 1.0 / n_steps)
    g0, g1 = lq_chains(dyn, [leg.reaching_cost(G0, 1.0 / n_steps), leg.reaching_cost(G1, 1.0 / n_steps)], X0, n_steps)
    p = [sum((Fraction(1, n_steps) * Fraction(u) for u in g1.mean[:, i]), Fraction(0)) for i in range(2)]
    truth = float(sum((pi - Fraction(g)) ** 2 for pi, g in zip(p, G1)) - sum((pi - Fraction(g)) ** 2
                                                                            for pi, g in zip(p, G0)))
    assert log_ratio_prefix(g1.mean, g0, g1)[-1] == pytest.approx(truth, rel=1e-12)
    with pytest.raises(ValueError, match="would need"):
        g0.precision()
