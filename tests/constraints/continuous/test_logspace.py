"""Sums in log space of the point model: against scipy's logsumexp, and bit for bit against NumPy's own
reduction of the same axis where the sum is taken array by array (fewer than 8 entries)."""

import numpy as np
import pytest
from scipy.special import logsumexp as scipy_logsumexp

from mutual.constraints.continuous.logspace import SHORT, logsumexp, logsumexp_rows


def _values(n, k, seed):
    rng = np.random.default_rng(seed)
    v = rng.normal(scale=40.0, size=(n, k))
    v[rng.random(v.shape) < 0.25] = -np.inf
    v[:3] = -np.inf                                  # rows with nothing allowed: log 0
    return v


@pytest.mark.parametrize("k", [1, 2, 5, SHORT - 1, SHORT, 16, 80])
def test_logsumexp_matches_scipy_and_gives_minus_infinity_for_an_empty_sum(k):
    v = _values(500, k, k)
    with np.errstate(divide="ignore"):
        expected = scipy_logsumexp(v, axis=1)
    got = logsumexp(v, axis=1)
    assert np.all(np.isneginf(got[:3])) and np.array_equal(np.isneginf(got), np.isneginf(expected))
    finite = np.isfinite(expected)
    np.testing.assert_allclose(got[finite], expected[finite], rtol=1e-13, atol=1e-12)


@pytest.mark.parametrize("k", range(1, SHORT))
def test_a_short_axis_summed_array_by_array_equals_numpys_reduction_bit_for_bit(k):
    v = _values(20_000, k, 100 + k)
    m = np.max(v, axis=1, keepdims=True)
    shift = np.where(np.isfinite(m), m, 0.0)
    with np.errstate(divide="ignore"):
        numpy_order = np.log(np.exp(v - shift).sum(axis=1)) + shift[:, 0]
    assert np.array_equal(logsumexp(v, axis=1), numpy_order)
    assert np.array_equal(logsumexp_rows([v[:, j].copy() for j in range(k)]), numpy_order)
