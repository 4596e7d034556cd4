"""Dragan & Srinivasa's legibility baseline against its definitions, finite differences, brute force and
symmetry; bad inputs (tables)."""

import numpy as np
import pytest

from mutual.motion.legible import dragan
from mutual.motion.legible.dragan import (goal_posterior, gradient_linear_structure, legibility_score,
                                          optimise_legibility, score_gradient, score_weights, trajectory_cost)


GOALS = np.array([[-1.0, 1.0], [1.0, 1.0]])
S = np.zeros(2)


def test_posterior_matches_the_full_formula():
    """P(G | xi_{S->Q}) = exp(-C[xi_{S->Q}] - V_G(Q)) / exp(-V_G(S)) P(G) / Z, with C not cancelled by hand."""
    rng = np.random.default_rng(0)
    goals = rng.normal(size=(4, 2))
    prior = np.array([0.1, 0.2, 0.3, 0.4])
    path = np.cumsum(rng.normal(scale=0.1, size=(30, 2)), axis=0)
    C = trajectory_cost(np.vstack([S, path]))
    Q = path[-1]
    V = lambda q: 0.5 * np.sum((goals - q) ** 2, axis=1)  # noqa: E731
    unnorm = np.exp(-C - V(Q)) / np.exp(-V(S)) * prior
    np.testing.assert_allclose(goal_posterior(Q, S, goals, prior), unnorm / unnorm.sum(), rtol=1e-12)


def test_posterior_at_start_is_the_prior():
    np.testing.assert_allclose(goal_posterior(S, S, GOALS, [0.3, 0.7]), [0.3, 0.7])


def test_score_weights_integrate_f():
    """Trapezoid weights of f(t) = T - t: they sum to one and give int t f / int f = T / 3."""
    w = score_weights(1000, T=2.0)
    t = np.linspace(0, 2.0, 1001)
    assert w.sum() == pytest.approx(1.0)
    assert w @ t == pytest.approx(2.0 / 3, rel=1e-5)
    assert np.all(np.diff(w[1:-1]) < 0)      # earlier moments weigh more


def test_score_gradient_matches_finite_differences():
    rng = np.random.default_rng(1)
    xs = np.linspace(S, GOALS[1], 21) + 0.1 * rng.normal(size=(21, 2))
    xs[0], xs[-1] = S, GOALS[1]
    grad = score_gradient(xs, GOALS, 1)
    eps = 1e-6
    fd = np.zeros_like(grad)
    for k in range(1, 20):
        for d in range(2):
            plus, minus = xs.copy(), xs.copy()
            plus[k, d] += eps
            minus[k, d] -= eps
            fd[k - 1, d] = (legibility_score(plus, GOALS, 1) - legibility_score(minus, GOALS, 1)) / (2 * eps)
    np.testing.assert_allclose(grad, fd, atol=1e-8)


@pytest.fixture(scope="module")
def optimised():
    return optimise_legibility(S, GOALS, 1, N=100, beta_ratio=1.5)


def test_optimiser_improves_within_the_trust_region(optimised):
    r = optimised
    straight = np.linspace(S, GOALS[1], 101)
    assert r.scores[-1] > legibility_score(straight, GOALS, 1) + 0.05
    assert r.costs[-1] <= 1.5 * trajectory_cost(straight) * (1 + 1e-6)
    np.testing.assert_allclose(r.xs[[0, -1]], [S, GOALS[1]])


def test_optimiser_exaggerates_away_from_the_other_goal(optimised):
    mid = optimised.xs[50]
    assert mid[0] > 0.5 + 0.2          # bulges right of the straight line, away from G0 = (-1, 1)
    np.testing.assert_allclose(mid[1], 0.5, atol=1e-6)   # symmetric goals: no vertical distortion


def test_optimiser_is_mirror_symmetric(optimised):
    left = optimise_legibility(S, GOALS, 0, N=100, beta_ratio=1.5)
    np.testing.assert_allclose(left.xs * [-1, 1], optimised.xs, atol=1e-9)


def test_trust_region_binds_the_result():
    """A larger trust region allows a more legible (higher score) trajectory."""
    small = optimise_legibility(S, GOALS, 1, N=60, beta_ratio=1.2)
    large = optimise_legibility(S, GOALS, 1, N=60, beta_ratio=2.0)
    assert large.scores[-1] > small.scores[-1]


@pytest.mark.parametrize("kwargs,match", [
    (dict(goal_index=2), "goal_index"),
    (dict(beta=0.5), "empty trust region"),
    (dict(eta=0.0), "eta must be a positive"),
    (dict(N=1), "N must be"),
])
def test_bad_inputs(kwargs, match):
    args = dict(start=S, goals=GOALS, goal_index=1)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        optimise_legibility(**args)
    with pytest.raises(ValueError, match="goals must be"):
        goal_posterior(S, S, GOALS[:1])


def test_banded_metric_solve_equals_the_explicit_inverse():
    """The library solves M step = grad with a banded Cholesky; three iterations by an explicit M^-1 agree."""
    N, dt = 40, 1.0 / 40
    banded = optimise_legibility(S, GOALS, 1, N=N, max_iter=3, tol=0.0)
    Minv = np.linalg.inv((2 * np.eye(N - 1) - np.eye(N - 1, k=1) - np.eye(N - 1, k=-1)) / dt)
    xs = np.linspace(0.0, 1.0, N + 1)[:, None] * GOALS[1]
    beta = 1.5 * trajectory_cost(xs)
    for _ in range(3):
        inner = xs[1:-1]
        gL, gC = score_gradient(xs, GOALS, 1), (2 * inner - xs[:-2] - xs[2:]) / dt
        sL, sC = Minv @ gL, Minv @ gC
        cost = trajectory_cost(xs)
        lam = (np.sum(gC * sL) - 0.3 * (beta - cost)) / np.sum(gC * sC)
        step = sL - max(lam, 0.0) * sC if cost + np.sum(gC * sL) / 0.3 > beta else sL
        xs = xs.copy()
        xs[1:-1] = inner + step / 0.3
    np.testing.assert_allclose(banded.xs, xs, atol=1e-12)


def test_eq11_gradient_is_a_linear_combination_of_the_hypotheses():
    """Section 6.5 on D&S's eq. 11: the score's gradient (finite differences) lies in the span of the
    goals' cost-to-go gradients, truth weighted <= 0, distractors >= 0, weights summing to zero, as
    the posteriors predict. In 5-D with 3 goals the fit is overdetermined, so it could fail."""
    rng = np.random.default_rng(0)
    goals, start = rng.normal(size=(3, 5)), np.zeros(5)
    xs = optimise_legibility(start, goals, 0, N=20).xs
    out = gradient_linear_structure(xs, goals, 0)
    assert out["residual"] < 1e-8 and out["sum_ratio"] < 1e-6 and out["signs_ok"]
    np.testing.assert_allclose(out["coefficients"], out["predicted"], atol=1e-8)
    # a trajectory-independent direction is not in that span: the fit must then leave a residual
    basis = (xs[5] - goals).T
    outside = np.linalg.svd(basis)[0][:, -1]
    assert np.linalg.norm(basis @ np.linalg.lstsq(basis, outside, rcond=None)[0] - outside) > 0.99


def test_result_repr_is_short():
    r = optimise_legibility(S, GOALS, 1, N=30)
    text = repr(r)
    assert text.startswith("DraganResult(N=30, dim=2, iterations=") and "score" in text and len(text) < 140


DT, N = 0.1, 10
X0 = np.zeros(2)
XS = np.linspace([0.0, 0.0], [1.0, 1.0], N + 1)
NAN_XS = XS.copy()
NAN_XS[4, 0] = np.nan


CASES = [
    # Dragan and Srinivasa
    (dragan.legibility_score, (NAN_XS, GOALS, 1), {}, ValueError, "xs contains non-finite"),
    (dragan.legibility_score, (np.zeros((N + 1, 3)), GOALS, 1), {}, ValueError, "xs must be a (N+1 >= 2, 2)"),
    (dragan.legibility_score, (XS, GOALS, 1.5), {}, ValueError, "goal_index must index goals"),
    (dragan.goal_posterior, ([np.nan, 0.0], X0, GOALS), {}, ValueError, "points must be finite"),
    (dragan.trajectory_cost, (np.zeros((1, 2)),), {}, ValueError, "xs must be a"),
    (dragan.optimise_legibility, ([np.nan, 0.0], GOALS, 1), {}, ValueError, "start must be finite"),
    (dragan.optimise_legibility, ([1.0, 1.0], GOALS, 1), {}, ValueError, "coincides with the chosen goal"),
    (dragan.optimise_legibility, (X0, GOALS, 1), dict(beta=np.nan), ValueError, "not finite or below"),
    (dragan.optimise_legibility, (X0, GOALS, 1), dict(beta_ratio=0.5), ValueError, "beta_ratio must be"),
    (dragan.optimise_legibility, (X0, GOALS, 1), dict(tol=-1.0), ValueError, "tol must be"),
    (dragan.optimise_legibility, (X0, GOALS, 1), dict(max_iter=-1), ValueError, "max_iter must be"),
    (dragan.gradient_linear_structure, (XS, GOALS, 1), dict(eps=0.0), ValueError, "eps must be a positive"),
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
