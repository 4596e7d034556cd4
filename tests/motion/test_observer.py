"""The Boltzmann observer of eq. (6.8) in closed form: log_boltzmann is a Gaussian density, its prefix the
Gaussian marginal, the posterior Bayes' rule; the log-likelihood ratio stays exact at any scale of the
controls (checked against exact rational arithmetic); what float64 cannot represent, and dense sizes, are
refused before allocating; bad inputs (tables)."""

import tracemalloc
from fractions import Fraction

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from mutual.motion import belief, legible as leg, observer
from mutual.motion.chain import NotRepresentable, lq_chains
from mutual.motion.legible import anticipation, qp
from mutual.motion.observer import (lifted_cost, log_boltzmann, log_boltzmann_prefix, log_likelihood_ratio,
                                    posterior_over_time, weighted_prefix_log_likelihood)

from helpers.lq import random_hypotheses, rollout


DT, N = 0.01, 100
X0 = np.zeros(2)


def test_log_boltzmann_is_a_gaussian_density():
    """P(u | H) = exp(-J(u)) / Z is the Gaussian N(-H^-1 h, H^-1) (checked with scipy)."""
    dyn, J0, _, x0, N_ = random_hypotheses(1)
    H, h, _ = lifted_cost(dyn, J0, x0, N_)
    rng = np.random.default_rng(2)
    for _ in range(3):
        us = rng.normal(size=(N_, 2))
        expected = multivariate_normal(-np.linalg.solve(H, h), np.linalg.inv(H)).logpdf(us.reshape(-1))
        assert log_boltzmann(dyn, J0, x0, us) == pytest.approx(expected, rel=1e-9)


def test_equal_curvature_means_lambda_is_exp_cost_difference(reference):
    """For x' = u with eq. (6.17) both hypotheses have the same Hessian, so Z0 = Z1 and log Lambda = J1 - J0."""
    dyn, J1, J0 = reference
    us = np.random.default_rng(3).normal(size=(N, 2))
    xs = rollout(dyn, X0, us)
    assert log_likelihood_ratio(dyn, J0, J1, X0, us) == pytest.approx(J1.value(xs, us) - J0.value(xs, us))


def test_prefix_log_likelihood_is_the_gaussian_marginal():
    """log P(u_{0:k} | H) against scipy's marginal of N(mean, H^-1) over the first k m coordinates."""
    dyn, J0, _, x0, N_ = random_hypotheses(6)
    H, h, _ = lifted_cost(dyn, J0, x0, N_)
    mean, cov = -np.linalg.solve(H, h), np.linalg.inv(H)
    us = np.random.default_rng(1).normal(size=(N_, 2))
    prefix = log_boltzmann_prefix(dyn, J0, x0, us)
    assert prefix[0] == 0.0
    for k in (1, 4, N_):
        d = 2 * k
        expected = multivariate_normal(mean[:d], cov[:d, :d]).logpdf(us.reshape(-1)[:d])
        assert prefix[k] == pytest.approx(expected, rel=1e-9)
    assert prefix[-1] == pytest.approx(log_boltzmann(dyn, J0, x0, us), rel=1e-12)


def test_posterior_over_time_is_bayes_rule():
    dyn, J0, J1, x0, N_ = random_hypotheses(7)
    us = np.random.default_rng(2).normal(size=(N_, 2))
    post = posterior_over_time(dyn, [J0, J1], x0, us, prior=[0.25, 0.75])
    np.testing.assert_allclose(post[0], [0.25, 0.75])
    np.testing.assert_allclose(post.sum(axis=1), 1.0)
    odds = np.log(post[-1, 0] / post[-1, 1])
    assert odds == pytest.approx(log_likelihood_ratio(dyn, J0, J1, x0, us) + np.log(0.25 / 0.75), rel=1e-9)


def test_weighted_prefix_log_likelihood_is_the_weighted_sum():
    dyn, J0, _, x0, N_ = random_hypotheses(8)
    us = np.random.default_rng(3).normal(size=(N_, 2))
    w = np.random.default_rng(4).uniform(size=N_)
    Hw, hw, cw = weighted_prefix_log_likelihood(dyn, J0, x0, N_, w)
    u = us.reshape(-1)
    assert -(0.5 * u @ Hw @ u + hw @ u + cw) == pytest.approx(w @ log_boltzmann_prefix(dyn, J0, x0, us)[1:], rel=1e-10)


SMALL_DT, SMALL_N = 0.1, 10
SMALL_DYN = leg.single_integrator(2, SMALL_DT)
SMALL_G0, SMALL_G1 = (-1.0, 1.0), (1.0, 1.0)
SMALL_J0, SMALL_J1 = leg.reaching_cost(SMALL_G0, SMALL_DT), leg.reaching_cost(SMALL_G1, SMALL_DT)


def controls(scale, first=None):
    us = np.full((SMALL_N, 2), scale)
    if first is not None:
        us[0] = first
    return us


def exact_log_lambda(us):
    """log Lambda = J1(u) - J0(u) exactly: the hypotheses share their quadratic part and the goals are
    symmetric about the start (so J0* = J1*), and the effort cancels; p = x0 + dt sum u in rationals."""
    p = [sum((Fraction(SMALL_DT) * Fraction(u) for u in us[:, i]), Fraction(0)) for i in range(2)]
    d1 = sum((pi - Fraction(g)) ** 2 for pi, g in zip(p, SMALL_G1))
    d0 = sum((pi - Fraction(g)) ** 2 for pi, g in zip(p, SMALL_G0))
    return float(d1 - d0)


# ---- the log-likelihood ratio: exact where the squares are not (class: answered, exact) ------------------
RATIO = [1e16, 1e20, 1e200, 1e300, -1e16, 3.7e-3, 1e-170, 1e-300]
RATIO_MIXED = [(1e-200, 1e200), (1.0, 1e300), (1e200, -1e200)]


@pytest.mark.parametrize("us", [controls(c) for c in RATIO] + [controls(a, b) for a, b in RATIO_MIXED],
                         ids=[f"{c:g}" for c in RATIO] + [f"{b:g} then {a:g}" for a, b in RATIO_MIXED])
def test_log_likelihood_ratio_is_exact_at_any_scale(us):
    """1e16 gave -7.2e16 (truth -4e16), 1e20 gave 0 and 1e200 NaN: relative 1e-12 above 1 nat, absolute below."""
    truth = exact_log_lambda(us)
    got = observer.log_likelihood_ratio(SMALL_DYN, SMALL_J0, SMALL_J1, X0, us)
    assert abs(got - truth) <= 1e-12 * max(1.0, abs(truth))
    prefix = belief.posterior_over_time(us, *lq_chains(SMALL_DYN, [SMALL_J0, SMALL_J1], X0, SMALL_N))
    logit_truth = -truth                                 # P(H1 | u) = logistic(-log Lambda), equal priors
    assert np.all(np.isfinite(prefix)) and prefix[-1] == pytest.approx(0.5 * (1 + np.tanh(0.5 * logit_truth)),
                                                                       abs=1e-12)


@pytest.mark.parametrize("scale", [1e16, 1e200, 1e-300])
def test_posterior_over_several_hypotheses_is_a_distribution(scale):
    J2 = leg.reaching_cost((0.0, -1.0), SMALL_DT)
    post = observer.posterior_over_time(SMALL_DYN, [SMALL_J0, SMALL_J1, J2], X0, controls(scale))
    assert np.all(np.isfinite(post)) and np.allclose(post.sum(axis=1), 1.0, atol=1e-12)
    if scale > 1:                                        # far right and up: the goal (1, 1) wins outright
        assert post[-1, 1] == 1.0


@pytest.mark.parametrize("scale", [1e16, 1e200])
def test_dense_pairs_give_the_same_posterior(scale):
    """belief.posterior_over_time with (mean, precision) pairs: the same stable difference of squares."""
    chains = lq_chains(SMALL_DYN, [SMALL_J0, SMALL_J1], X0, SMALL_N)
    pairs = [tuple(g) for g in chains]
    np.testing.assert_allclose(belief.posterior_over_time(controls(scale), *pairs),
                               belief.posterior_over_time(controls(scale), *chains), atol=1e-12)


def test_a_single_log_density_is_exact_where_representable():
    """log P(u | H) at controls of 1e16 (about -4e32) against the Gaussian density written out densely."""
    us = controls(1e16)
    mean, H = belief.lq_gaussian(SMALL_DYN, SMALL_J0, X0, SMALL_N)
    e = us.reshape(-1) - mean.reshape(-1)
    truth = -0.5 * e @ H @ e + 0.5 * np.linalg.slogdet(H)[1] - SMALL_N * np.log(2 * np.pi)
    assert observer.log_boltzmann(SMALL_DYN, SMALL_J0, X0, us) == pytest.approx(truth, rel=1e-12)


# ---- what float64 cannot represent is refused (class: refused, named) ---------------------------------
UNREPRESENTABLE = [
    (observer.log_boltzmann, (SMALL_DYN, SMALL_J0, X0, controls(1e200)), "us: log P(u | H)"),
    (observer.log_boltzmann_prefix, (SMALL_DYN, SMALL_J1, X0, controls(-1e300)), "us: log P(u | H)"),
    (belief.gaussian_prefix_loglik, (controls(1e170), belief.lq_gaussian(SMALL_DYN, SMALL_J0, X0, SMALL_N)), "beyond float64"),
]


@pytest.mark.parametrize("fn, args, phrase", UNREPRESENTABLE, ids=[c[0].__name__ for c in UNREPRESENTABLE])
def test_what_float64_cannot_represent_is_refused(fn, args, phrase):
    with pytest.raises(NotRepresentable, match=phrase.replace("(", r"\(").replace(")", r"\)")):
        fn(*args)


# ---- sizes checked before allocating (class: refused, with the memory) --------------------------------
BIG = 10 ** 6


SIZES = [
    (observer.lifted_cost, (SMALL_DYN, SMALL_J0, X0, BIG), {}, "N = 1000000 steps"),
    (observer.likelihood_ratio_minimiser, (SMALL_DYN, SMALL_J0, SMALL_J1, X0, BIG), {}, "GiB"),
    (observer.sample_boltzmann, (SMALL_DYN, SMALL_J0, X0, BIG, 1, np.random.default_rng(0)), {}, "GiB"),
    (observer.batch_costs, (SMALL_DYN, SMALL_J0, X0, np.zeros((1, BIG, 2))), {}, "GiB"),
    (anticipation.weighted_evidence_optimum, (SMALL_DYN, SMALL_J1, SMALL_J0, X0, BIG), {}, "GiB"),
    (qp.multi_distractor_qp, (SMALL_DYN, SMALL_J1, [SMALL_J0], X0, BIG, -1.0), {"formulation": "dense"}, "GiB"),
]


@pytest.mark.parametrize("fn, args, kwargs, phrase", SIZES, ids=[c[0].__name__ for c in SIZES])
def test_dense_sizes_are_refused_before_allocating(fn, args, kwargs, phrase):
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=phrase) as err:
            fn(*args, **kwargs)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert "would need" in str(err.value) and peak < 100 * 2 ** 20


US = np.ones((SMALL_N, 2))
NAN_US = US.copy()
NAN_US[3, 1] = np.nan
INF_US = US.copy()
INF_US[0, 0] = np.inf


CASES = [
    # the Boltzmann observer
    (observer.log_likelihood_ratio, (SMALL_DYN, SMALL_J0, SMALL_J1, X0, NAN_US), {}, ValueError, "us contains non-finite"),
    (observer.log_likelihood_ratio, (SMALL_DYN, SMALL_J0, SMALL_J1, X0, INF_US), {}, ValueError, "us contains non-finite"),
    (observer.log_likelihood_ratio, (SMALL_DYN, SMALL_J0, SMALL_J1, X0, np.ones((SMALL_N, 3))), {}, ValueError, "us must be an (N, 2)"),
    (observer.log_likelihood_ratio, (SMALL_DYN, SMALL_J0, SMALL_J1, [0.0, np.nan], US), {}, ValueError, "x0 must be a finite vector"),
    (observer.log_boltzmann_prefix, (SMALL_DYN, SMALL_J0, X0, NAN_US), {}, ValueError, "us contains non-finite"),
    (observer.posterior_over_time, (SMALL_DYN, [SMALL_J0], X0, US), {}, ValueError, "at least two hypotheses"),
    (observer.posterior_over_time, (SMALL_DYN, [SMALL_J0, SMALL_J1], X0, US), dict(prior=[0.5, -0.5]), ValueError,
     "prior must be 2 positive"),
    (observer.likelihood_ratio_minimiser, (SMALL_DYN, SMALL_J0, SMALL_J1, X0, SMALL_N), dict(alpha=np.inf), ValueError,
     "alpha must be a finite"),
    (observer.sample_boltzmann, (SMALL_DYN, SMALL_J0, X0, SMALL_N, 0, np.random.default_rng(0)), {}, ValueError,
     "size must be a positive integer"),
    (observer.batch_costs, (SMALL_DYN, SMALL_J0, X0, NAN_US[None]), {}, ValueError, "us contains non-finite"),
]


@pytest.mark.parametrize("fn,args,kwargs,error,phrase", CASES,
                         ids=[f"{i}-{c[0].__name__ if hasattr(c[0], '__name__') else c[0]}" for i, c in
                              enumerate(CASES)])
def test_bad_input_is_refused_with_a_clear_message(fn, args, kwargs, error, phrase):
    if error is None:
        out = fn(*args, **kwargs)
        assert np.all(np.isfinite(out.us))
        return
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value)
