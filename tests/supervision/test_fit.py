"""The maximum-likelihood fit of a supervisor's safe set (eqs. 4.8-4.12): the Gaussian MLE against scipy, the
fit against its closed form, the argmax against the generating member, the MAP prior, the library's edge;
exact values where the closed form exists, coverage against Monte Carlo; bad inputs (a table)."""

import re
import warnings

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from mutual.supervision.control import safety_controller
from mutual.supervision.fit import (GridValueWarning, LibraryEdgeWarning, data_efficiency_scan, expected_coverage,
                                    fit_supervisor, gaussian_mle, member_values, recovery_study)
from mutual.supervision.reachability import QUICK_GRID, value_library
from mutual.supervision.supervisor import NoisySupervisor

from helpers.supervision import (GRID, RADIUS, STATES, case_id, head_on, simulated_interventions, small_fit,
                                 small_library, small_value_function)


W_MAXES = 0.25 * np.arange(1, 13)


def test_gaussian_mle_matches_scipy():
    x = np.random.default_rng(0).normal(0.4, 0.3, size=(3, 25))
    mu, sigma, loglik = gaussian_mle(x)
    for row, m, s, ll in zip(x, mu, sigma, loglik):
        m_ref, s_ref = stats.norm.fit(row)  # the MLE (population variance)
        assert m == pytest.approx(m_ref) and s == pytest.approx(s_ref)
        assert ll == pytest.approx(stats.norm.logpdf(row, m_ref, s_ref).sum())


def test_fit_equals_its_closed_form(library):
    states = simulated_interventions(library, 0.75, 0.5, 0.05, 30, seed=1)
    fit = fit_supervisor(library, states)
    values = member_values(library, states)  # the exact values the fit reads
    mu, sigma, loglik = gaussian_mle(values)
    assert np.allclose(fit.mus, mu) and np.allclose(fit.sigmas, sigma) and np.allclose(fit.logliks, loglik)
    assert fit.index == np.argmax(loglik) and fit.w_max == W_MAXES[fit.index]
    assert fit.level(2.0) == pytest.approx(fit.mu + 2 * fit.sigma)


@pytest.mark.parametrize("w_max", [0.5, 0.75, 1.0])
def test_argmax_recovers_the_generating_member(library, w_max):
    for seed in range(4):
        fit = fit_supervisor(library, simulated_interventions(library, w_max, 0.5, 0.02, 40, seed))
        assert fit.w_max == w_max, seed
        assert fit.mu == pytest.approx(0.5, abs=0.03)
        assert fit.sigma == pytest.approx(0.02, abs=0.02)


def test_map_prior_excludes_agile_members_and_clips_mu(library):
    states = simulated_interventions(library, 2.0, -0.1, 0.02, 40, seed=0)
    mle = fit_supervisor(library, states)
    assert mle.w_max > 1.0 and mle.mu < 0
    with pytest.warns(LibraryEdgeWarning, match="MAP prior's support"):
        fit = fit_supervisor(library, states, prior="map")
    assert np.array_equal(fit.admissible, W_MAXES <= 1.0)
    assert fit.w_max <= 1.0 and fit.mu >= 0
    assert np.all(np.isneginf(fit.logliks[~fit.admissible]))
    values = member_values(library, states)[fit.index]
    mu = max(values.mean(), 0.0)
    assert fit.sigma == pytest.approx(np.sqrt(np.mean((values - mu) ** 2)))


def test_fit_rejects_degenerate_data(library):
    good = simulated_interventions(library, 1.0, 0.5, 0.1, 10, seed=0)
    with pytest.raises(ValueError, match="at least two"):
        fit_supervisor(library, good[:1])
    with pytest.raises(ValueError, match="NaN"):
        fit_supervisor(library, np.vstack([good, [[np.nan, 0.0, 0.0]]]))
    with pytest.raises(ValueError, match="outside"):
        fit_supervisor(library, np.vstack([good, [[20.0, 0.0, 0.0]]]))
    with pytest.raises(ValueError, match="zero variance"):
        fit_supervisor(library, np.repeat(good[:1], 5, axis=0))
    with pytest.raises(ValueError, match="prior"):
        fit_supervisor(library, good, prior="flat")
    with pytest.raises(ValueError, match="shape"):
        fit_supervisor(library, good[:, :2])


def _no_warning(func, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return func(*args, **kwargs)


def test_a_fit_beyond_the_library_says_it_sits_on_the_edge(library):
    """A supervisor more agile (or slower) than every member is fitted to the library's edge,
    with a warning and ``fit.boundary`` -- and an interior fit says nothing."""
    inner = value_library([0.5, 0.75, 1.0, 1.25, 1.5], RADIUS, QUICK_GRID, progress=False)
    agile = simulated_interventions(library, 3.0, 0.5, 0.02, 40, seed=0)
    with pytest.warns(LibraryEdgeWarning, match=r"most agile member of the library \(w_max = 1.5"):
        fit = fit_supervisor(inner, agile)
    assert fit.boundary == "highest" and fit.w_max == 1.5
    slow = simulated_interventions(library, 0.25, 0.5, 0.02, 40, seed=1)
    with pytest.warns(LibraryEdgeWarning, match="slowest-turning member"):
        assert fit_supervisor(inner, slow).boundary == "lowest"
    inside = _no_warning(fit_supervisor, inner, simulated_interventions(library, 1.0, 0.5, 0.02, 40, seed=2))
    assert inside.boundary is None and inside.w_max == 1.0
    single = value_library([1.0], RADIUS, QUICK_GRID, progress=False)
    with pytest.warns(LibraryEdgeWarning, match="only member"):
        assert fit_supervisor(single, agile).boundary == "only"


def test_recovery_study_records_the_edge_instead_of_warning(library):
    inner = value_library([0.5, 0.75, 1.0], RADIUS, QUICK_GRID, progress=False)
    table = _no_warning(recovery_study, inner, [(1.0, 0.5, 0.02), (0.5, 0.5, 0.02)], [5, 10], [0, 1], 7.5)
    assert len(table) == 8
    assert set(table.loc[table["w_max"] == 1.0, "boundary"]) == {"highest"}
    assert (table.loc[table["boundary"] == "", "w_max_hat"] == 0.75).all()


def test_fit_and_supervisor_print_short_summaries(library):
    fit = fit_supervisor(library, simulated_interventions(library, 0.75, 0.5, 0.05, 40, seed=1))
    text = repr(fit)
    for word in ["w_max=0.75", "mu=", "sigma=", "n=40", "prior='mle'", "mu+2sigma=", "12 members", "boundary=None"]:
        assert word in text, (word, text)
    assert len(text) < 300 and "array" not in text
    assert fit.logliks.shape == (12,) and fit.library is library  # the full data stays available
    sup = NoisySupervisor(library[1], 0.5, 0.1)
    assert repr(sup).startswith("NoisySupervisor(w_max=0.5, mu=0.5, sigma=0.1;") and len(repr(sup)) < 200
    controller = safety_controller(library[1], 0.6, u_max=1.0)
    assert "alpha=0.6" in repr(controller) and len(repr(controller)) < 200


def test_the_fit_reads_exact_values_and_warns_on_the_grid():
    rng = np.random.default_rng(2)
    v = 0.5 + 0.1 * rng.standard_normal(40)
    states = head_on(v, rng)
    lib = value_library([1.0], 1.0, GRID, method="closed-form")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        exact_fit = fit_supervisor(lib, states)
        assert not any(issubclass(w.category, GridValueWarning) for w in caught)
        grid_fit = fit_supervisor(lib, states, values="grid")
    assert exact_fit.values == "exact" and exact_fit.mu == pytest.approx(v.mean(), abs=1e-9)
    assert grid_fit.mu - v.mean() > 0.1 and grid_fit.value_error > 0.1
    assert any(issubclass(w.category, GridValueWarning) for w in caught)
    np.testing.assert_allclose(member_values(lib, states)[0], v, atol=1e-12)


def test_expected_coverage_against_monte_carlo():
    rng = np.random.default_rng(5)
    x = rng.standard_normal((100_000, 40))
    u = (x - x.mean(axis=1, keepdims=True)) / x.std(axis=1, keepdims=True)
    assert expected_coverage(2.0, 40) == pytest.approx(np.mean(u <= 2), abs=3e-4)
    assert expected_coverage(2.0, 10 ** 6) == pytest.approx(0.97725, abs=1e-4)
    with pytest.raises(ValueError, match="p must be"):
        expected_coverage(2.0, 2)


def test_data_efficiency_scan_counts_sessions():
    rows = [{"w_max": w, "sigma": s, "seed": k, "n": 40, "recovered": k < (10 if s == 0.05 else 5)}
            for w in (0.5, 0.75) for s in (0.05, 0.2) for k in range(10)]
    cells, scan = data_efficiency_scan(pd.DataFrame(rows), 40, (0.75, 0.05), table_name="t")
    assert scan["seeds"] == [10, 10] and scan["settings"] == [2, 4] and "sigma 0.2: 5/10" in scan["flips"]
    assert len(cells) == 4


CASES = [
    # the maximum-likelihood fit
    (lambda: fit_supervisor(small_library(), STATES, prior="MAP "), (), {}, ValueError, "prior must be 'mle' or 'map'"),
    (fit_supervisor, ("library", STATES), {}, ValueError, "library must be a mutual.supervision.ValueLibrary"),
    (lambda: fit_supervisor(small_library(), STATES, reference=small_value_function()), (), {}, ValueError,
     "reference is used only with prior='map'"),
    (lambda: fit_supervisor(value_library([0.5, 0.75], 1.0, GRID, method="closed-form"), STATES, prior="map"), (), {},
     ValueError, "prior='map' needs reference="),
    (lambda: fit_supervisor(small_library(), np.vstack([STATES, [[12.0, 0.0, 0.0]]])), (), {}, ValueError,
     "lie outside the library's grid"),
    (lambda: small_fit().level(np.nan), (), {}, ValueError, "k must be a finite number"),
    (lambda: small_fit().coverage([[20.0, 0.0, 0.0]]), (), {}, ValueError, "lie outside the library's grid"),
    (lambda: recovery_study(small_library(), [(0.75, 0.5)], [10], [0], 7.5), (), {}, ValueError,
     "(w_max, mu, sigma) triples"),
    (lambda: recovery_study(small_library(), [(0.75, 0.5, 0.1)], [1], [0], 7.5), (), {}, ValueError,
     "n_values must be integers >= 2"),
]


@pytest.mark.parametrize("func, args, kwargs, error, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_raises_a_clear_error(func, args, kwargs, error, phrase):
    with pytest.raises(error, match=re.escape(phrase)):
        func(*args, **kwargs)
