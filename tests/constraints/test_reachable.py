"""Restricting the backup to the states the demonstrations' starts reach (``mutual.constraints.reachable``):
the restricted compiled backup equals the numpy backup on the whole MDP, and the restriction keeps every
state a breadth-first search reaches."""

import numpy as np
import pytest
import scipy.sparse as sp

from mutual.constraints import MDP, gather, rank_candidates
from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.feasibility import infeasible_candidates
from mutual.constraints.gather import gather_form
from mutual.constraints.reachable import first_reached, restricted


TOLERANCE = 1e-10
LONG = (41, 44, 48, 53, 57)     # states whose action 0 has many successors


def chain(seed, X=600, A=3, T=8):
    """A random MDP on a line of X states, each action moving a few states with noise (so the starts
    reach a small part of it within T), a few pairs with many successors, and a start mass on three
    states."""
    rng = np.random.default_rng(seed)
    rows, cols, data = [], [], []
    for x in range(X):
        for a in range(A):
            long = x in LONG and a == 0
            n, spread = (12, 7) if long else (rng.integers(1, 4), 2)
            to = np.clip(x + (a - 1) * 2 + rng.integers(-spread, spread + 1, size=n), 0, X - 1)
            p = rng.random(n) + 0.1
            rows += [x * A + a] * n
            cols += list(to)
            data += list(p / p.sum())
    S = sp.csr_matrix((data, (rows, cols)), shape=(X * A, X))
    initial = np.zeros(X)
    initial[[40, 45, 52]] = [0.5, 0.3, 0.2]
    reward = -np.abs(np.arange(X)[:, None] - 60) / 30.0 + rng.normal(0, 0.1, size=(X, A))
    return MDP(S, reward, T, terminal_reward=-np.abs(np.arange(X) - 60) / 10.0, initial=initial)


def candidates(mdp, seed, K=24):
    """Random forbidden sets near the starts, some of them making a demonstration infeasible."""
    rng = np.random.default_rng(seed)
    F = np.zeros((mdp.n_states, mdp.n_actions, K), dtype=bool)
    for k in range(K):
        x = rng.integers(30, 70, size=rng.integers(1, 6))
        F[x, rng.integers(0, mdp.n_actions, size=x.size), k] = True
    return F


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_restricted_compiled_backup_equals_the_numpy_backup_on_the_whole_mdp(seed, monkeypatch):
    monkeypatch.setattr(gather, "OVERFLOW_SHARE", 0.05)     # the few long rows go to auxiliary rows
    mdp = chain(seed)
    demos = sample_demonstrations(mdp, 6, rng=seed)
    F = candidates(mdp, seed)
    part = restricted(mdp, demos.states[:, 0])
    assert part is not None and part.states.size < mdp.n_states / 2     # the test exercises the restriction
    assert gather_form(part.mdp).extra_P.shape[0] > 1                    # ... and the auxiliary rows
    truth_f, truth_gain = rank_candidates(mdp, demos, F, engine="numpy", reachable=False)
    assert np.isinf(truth_gain).any() and np.isfinite(truth_gain).sum() >= 5
    for engine in ("gather", "numpy"):
        for reachable in (True, False):
            log_f, gain = rank_candidates(mdp, demos, sp.csr_matrix(F.reshape(-1, F.shape[2])), engine=engine,
                                          reachable=reachable)
            live = np.isfinite(truth_gain)
            np.testing.assert_array_equal(np.isfinite(gain), live)
            np.testing.assert_allclose(log_f[live], truth_f[live], rtol=0, atol=TOLERANCE)
            np.testing.assert_allclose(gain[live], truth_gain[live], rtol=0, atol=TOLERANCE)
    dead = infeasible_candidates(mdp, demos, np.ones((mdp.n_states, mdp.n_actions), dtype=bool), F)
    np.testing.assert_array_equal(dead, ~np.isfinite(truth_gain))


def test_the_restriction_keeps_every_state_the_starts_reach_by_breadth_first_search():
    mdp = chain(3, X=120, T=5)
    starts = [40, 52]
    step = first_reached(mdp, starts)
    S = mdp.dense_transitions() > 0
    frontier, want = {40, 52}, np.full(mdp.n_states, -1)
    for t in range(mdp.horizon + 1):                    # plain breadth-first search over the support of S
        for x in frontier:
            want[x] = t if want[x] < 0 else want[x]
        frontier = {int(y) for x in frontier for y in np.flatnonzero(S[x].any(axis=0)) if want[y] < 0}
    np.testing.assert_array_equal(step, want)
    part = restricted(mdp, starts)
    assert part.layers[-1] == part.states.size == (want >= 0).sum()
    assert np.all(np.diff(want[part.states]) >= 0)      # numbered by the step they are first reached
