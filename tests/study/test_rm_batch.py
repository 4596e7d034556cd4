"""The vectorized chapter 5 analysis equals the study's own statistics (and leaves undefined what they
refuse); simulated Gaussian repeated-measures data have the asked moments and the test its level;
bad inputs (a table)."""

import numpy as np
import pandas as pd
import pytest

from mutual.study import rm_batch as rb, stats as st


def _study_analysis(y):
    levels = [f"L{j}" for j in range(y.shape[1])]
    long = pd.DataFrame({"s": np.repeat(np.arange(y.shape[0]), y.shape[1]), "t": np.tile(levels, y.shape[0]),
                         "v": y.ravel()})
    a = st.rm_anova(long, dv="v", within="t", subject="s", levels=levels)
    return a, st.tukey_rm(a), st.paired_t_holm(a.cells)


@pytest.mark.parametrize("n, m, seed", [(6, 3, 0), (11, 3, 1), (9, 4, 2), (25, 3, 3)])
def test_batch_analysis_equals_the_study_functions(n, m, seed):
    rng = np.random.default_rng(seed)
    y = rng.poisson(5, (3, n, m)) / 2 + rng.normal(0, 1, (3, n, 1))  # counts per trial, subject offsets
    res = rb.rm_analyses(y)
    for r in range(3):
        a, tukey, holm = _study_analysis(y[r])
        assert [res.F[r], res.p[r], res.p_gg[r], res.epsilon_gg[r], res.mse[r]] == pytest.approx(
            [a.F, a.p, a.p_gg, a.epsilon_gg, a.mse], rel=1e-9, abs=1e-12)
        assert res.q[r] == pytest.approx(tukey["q"].to_numpy(), rel=1e-9)
        assert res.diff[r] == pytest.approx(tukey["diff"].to_numpy(), rel=1e-9, abs=1e-12)
        assert res.tukey_p()[r] == pytest.approx(tukey["p"].to_numpy(), rel=1e-6, abs=1e-9)
        assert res.t[r] == pytest.approx(holm["t"].to_numpy(), rel=1e-9)
        assert res.p_holm[r] == pytest.approx(holm["p_holm"].to_numpy(), rel=1e-9, abs=1e-12)
        assert (res.tukey_reject(0.05)[r] == (tukey["p"].to_numpy() < 0.05)).all()


DEGENERATE = {
    "zero residual": [[1.0, 2.0, 3.0], [2.0, 3.0, 4.0], [0.0, 1.0, 2.0]],
    "no within-subject variation": [[2.0, 2.0, 2.0], [5.0, 5.0, 5.0], [1.0, 1.0, 1.0]],
}


@pytest.mark.parametrize("name", sorted(DEGENERATE))
def test_batch_analysis_leaves_undefined_what_the_study_refuses(name):
    """Where the study's rm_anova raises DegenerateDataError the batch gives NaN, which never rejects."""
    y = np.array(DEGENERATE[name])
    with pytest.raises(st.DegenerateDataError):
        _study_analysis(y)
    res = rb.rm_analyses(y[None])
    assert np.isnan(res.F[0]) and np.isnan(res.q[0]).all() and not res.tukey_reject()[0].any()
    assert not (res.p_gg < 0.05).any()


def test_batch_paired_t_is_undefined_for_constant_differences():
    y = np.array([[1.0, 2.0, 0.5], [2.0, 3.0, 4.0], [0.0, 1.0, 2.5], [4.0, 5.0, 1.0]])  # levels 0 and 1 differ by 1
    with pytest.raises(st.DegenerateDataError, match="paired differences"):
        st.paired_t_holm(pd.DataFrame(y))
    res = rb.rm_analyses(y)
    assert np.isnan(res.t[0, 0]) and np.isfinite(res.t[0, 1:]).all() and np.isfinite(res.F[0])


def test_gaussian_simulation_has_the_asked_moments():
    means, cov = np.array([1.0, 0.0, -0.5]), rb.compound_symmetry(3, 0.4, sd=2.0)
    y = rb.simulate_gaussian_rm(means, cov, 50, 400, seed=3).reshape(-1, 3)
    assert np.allclose(y.mean(0), means, atol=0.05)
    assert np.allclose(np.cov(y, rowvar=False), cov, atol=0.12)
    assert np.std(rb.means_with_effect(0.35, 4)) == pytest.approx(0.35)


def test_level_type_i_error():
    """Under H0 the GG-corrected F rejects at about alpha, also without sphericity."""
    cov = np.array([[1.0, 0.8, 0.1], [0.8, 1.0, 0.2], [0.1, 0.2, 1.5]])
    reps = 6000
    sim = rb.gaussian_rm_power(np.zeros(3), cov, 12, reps=reps, seed=11)
    assert abs(sim["anova_gg"] / reps - 0.05) < 4 * np.sqrt(0.05 * 0.95 / reps) + 0.01


CASES = [
    (rb.rm_analyses, (np.zeros((2, 1, 3)),), {}, "y must have shape (R, n >= 2, m >= 2)"),
    (rb.rm_analyses, (np.full((1, 4, 3), np.nan),), {}, "finite numbers"),
    (rb.compound_symmetry, (3, -0.6), {}, "rho must lie in (-1/(m-1), 1)"),
    (rb.simulate_gaussian_rm, (np.zeros(3), np.eye(2), 5, 10), {}, "symmetric (3, 3) matrix"),
    (rb.simulate_gaussian_rm, (np.zeros(3), -np.eye(3), 5, 10), {}, "positive semi-definite"),
    (rb.simulate_gaussian_rm, (np.zeros(3), np.eye(3), 1, 10), {}, "n must be an integer >= 2"),
    (rb.simulate_gaussian_rm, (np.zeros(3), np.eye(3), 5, 0), {}, "reps >= 1"),
]


@pytest.mark.parametrize("fn, args, kwargs, phrase", CASES,
                         ids=[f"{getattr(c[0], '__name__', 'call')}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, phrase):
    with pytest.raises(ValueError) as err:
        fn(*args, **kwargs)
    assert phrase in str(err.value), f"{err.value!s} does not say {phrase!r}"
