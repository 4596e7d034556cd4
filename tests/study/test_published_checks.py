"""Checks of the thesis's chapter 5 text from its own numbers (mutual.study.published): Table 5.1's
predicted against its observed false positives (Sec. 5.3.3) with standard errors checked by Monte Carlo,
and the arcs of line 1010 against the clusters of Fig. 5.5 (line 1024) by hand-made cases."""

import numpy as np
import pandas as pd
import pytest

from mutual.study.published import TABLE_5_1_COLUMNS, arcs_against_clusters, prediction_agreement

THESIS = pd.DataFrame([["Standard", 397, 440, 1.0, 12.54, 1.0], ["Learned", 220, 440, 0.554, 7.31, 0.583],
                       ["Conservative", 115, 440, 0.29, 4.68, 0.373]], columns=TABLE_5_1_COLUMNS)


def table(counts, means, total=440):
    """A Table 5.1 with these Phase II counts in (Standard, Learned, Conservative) and these mean false positives."""
    rows = [[name, c, total, c / counts[0], m, m / means[0]]
            for name, c, m in zip(("Standard", "Learned", "Conservative"), counts, means)]
    return pd.DataFrame(rows, columns=TABLE_5_1_COLUMNS)


def f_for(means, sigma, n):
    """The one-way repeated-measures F whose error mean square is sigma^2 for these level means."""
    return n * np.var(means, ddof=1) / sigma ** 2


def test_the_observed_ratios_spread_matches_monte_carlo():
    """se_observed (delta method, RM error term) against the spread of mean ratios in simulated studies
    without a participant effect: n = 11 people, three levels, Gaussian errors."""
    means, sigma, n = np.array([12.54, 7.31, 4.68]), 4.5, 11
    _, rows = prediction_agreement(table((397, 220, 115), means), f_for(means, sigma, n), 2, 2 * (n - 1))
    rng = np.random.default_rng(0)
    y = means + sigma * rng.standard_normal((40_000, n, 3))
    level_means = y.mean(axis=1)
    ratios = level_means[:, 1:] / level_means[:, :1]
    assert rows["se_observed"].to_numpy() == pytest.approx(ratios.std(axis=0), rel=0.05)


def test_the_predicted_ratios_spread_matches_monte_carlo():
    """se_predicted against the spread of the share of Standard-safe interventions that also lie in a smaller safe set."""
    _, rows = prediction_agreement(THESIS, 8.72, 2, 20)
    rng = np.random.default_rng(1)
    shares = rng.binomial(397, [220 / 397, 115 / 397], size=(40_000, 2)) / 397
    assert rows["se_predicted"].to_numpy() == pytest.approx(shares.std(axis=0), rel=0.05)


def test_the_thesis_table_is_judged_on_its_own_numbers():
    agree, rows = prediction_agreement(THESIS, 8.72, 2, 20)
    assert agree and list(rows["safe_set"]) == ["Learned", "Conservative"]
    assert rows["predicted"].to_numpy() == pytest.approx([220 / 397, 115 / 397])
    assert rows["observed"].to_numpy() == pytest.approx([7.31 / 12.54, 4.68 / 12.54])


@pytest.mark.parametrize("counts, means, F, why", [
    ((397, 220, 115), (12.54, 11.9, 4.68), 8.72, "Learned observed 0.95 against 0.55 predicted"),
    ((397, 115, 220), (12.54, 7.31, 4.68), 8.72, "the predicted order is the reverse of the observed one"),
    ((397, 380, 115), (12.54, 12.0, 4.68), 8.72, "Learned predicted 0.96, no decrease to speak of"),
    ((397, 220, 115), (12.54, 7.31, 4.68), 0.9, "a noisy study: the tolerance exceeds the predicted decrease"),
])
def test_tables_that_do_not_agree(counts, means, F, why):
    agree, _ = prediction_agreement(table(counts, means), F, 2, 20)
    assert not agree, why


@pytest.mark.parametrize("tbl, F, kwargs, message", [
    (THESIS, 8.72, {"z": 0}, "z must be a positive finite number"),
    (THESIS, 8.72, {"z": True}, "z must be a positive finite number"),
    (table((397, 420, 115), (12.54, 7.31, 4.68)), 8.72, {}, "more interventions than the Standard one"),
    (THESIS.drop(columns="average_fp"), 8.72, {}, "missing ['average_fp']"),
    (THESIS.assign(average_fp=["12.54", "x", "4.68"]), 8.72, {}, "non-negative finite numbers"),
    (THESIS, 8.72, {"df_num": 1}, "implies 2 levels"),
])
def test_bad_tables_are_refused(tbl, F, kwargs, message):
    args = {"df_num": 2, "df_den": 20} | kwargs
    with pytest.raises(ValueError, match=__import__("re").escape(message)):
        prediction_agreement(tbl, F, args.pop("df_num"), args.pop("df_den"), **args)


@pytest.mark.parametrize("shorter, analysed, clusters, consistent, conservative_at_least", [
    (9, 11, (3, 3, 5), True, 1),    # the thesis: two sets are not shorter, so one conservative-like set is
    (8, 11, (3, 3, 5), True, 0),
    (11, 11, (3, 3, 5), True, 3),
    (9, 11, (3, 3, 6), False, 1),   # the clusters hold 12 sets, not the 11 analysed
    (2, 11, (3, 3, 5), False, 0),   # fewer shorter arcs than standard-like sets
])
def test_arcs_against_clusters(shorter, analysed, clusters, consistent, conservative_at_least):
    out = arcs_against_clusters(shorter, analysed, dict(zip(("standard-like", "conservative-like", "gradual"), clusters)))
    assert out["consistent"] is consistent and out["not_shorter"] == analysed - shorter
    assert out["at_least_shorter"]["conservative-like"] == conservative_at_least


@pytest.mark.parametrize("args, message", [
    ((9.0, 11, {"standard-like": 3}), "shorter must be a whole number"),
    ((9, -1, {"standard-like": 3}), "analysed must be a whole number"),
    ((9, 11, {"standard-like": True}), "clusters['standard-like'] must be a whole number"),
    ((9, 11, {"gradual": 5}), "no 'standard-like' cluster"),
    ((12, 11, {"standard-like": 3}), "shorter (12) counts some of the analysed participants (11)"),
])
def test_bad_counts_are_refused(args, message):
    with pytest.raises(ValueError, match=__import__("re").escape(message)):
        arcs_against_clusters(*args)
