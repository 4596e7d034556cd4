"""Measuring how the constraint ranking's cost grows (Section 2.4, O(|X|^2 |A| |C|)).

Two measures of the same runs: the multiply-adds the backups actually perform in
their products with S -- counted while the code runs, so deterministic and
machine-independent, the measure the notebooks report -- and best-of-n wall time,
which varies from machine to machine and belongs to ``make bench`` and to
figures shown, never saved.
"""

import time
from contextlib import contextmanager
from unittest import mock

import numpy as np

from . import mdp as mdp_module
from .chance import chance_forbidden
from .backup import constraint_accrual, expected_features, log_partition, value_ratio
from .gridworld import gridworld


def best_time(fn, repeats=3):
    """The smallest wall time (seconds) of ``repeats`` calls of ``fn()``."""
    if repeats < 1:
        raise ValueError(f"repeats: must be >= 1, got {repeats!r}")
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


@contextmanager
def counting_multiply_adds():
    """Within the block, tally every product of S (as an (X*A, X) matrix) with a value
    matrix that the backups (Algorithms 3 and 4, the soft backup) perform, and every product of
    S^T with a mass matrix in the forward passes (Algorithms 1 and 2).

    Yields a dict: ``products`` (how many) and ``multiply_adds`` (their work: the
    entries of S a product touches -- all X^2 A of a dense S, the nnz of a sparse
    one -- times the value matrix's columns). The element-wise log-sum-exp over
    actions, O(|X||A|) per column and step, is of lower order and not counted.
    """
    tally = {"products": 0, "multiply_adds": 0}

    def counting(product):
        def counted(mdp, V):
            entries = mdp.transitions.nnz if mdp.is_sparse else mdp.transitions.size
            tally["products"] += 1
            tally["multiply_adds"] += int(entries) * (V.shape[1] if V.ndim == 2 else 1)
            return product(mdp, V)
        return counted

    with mock.patch.object(mdp_module, "_times_transitions", counting(mdp_module._times_transitions)), \
            mock.patch.object(mdp_module, "_transpose_times", counting(mdp_module._transpose_times)):
        yield tally


def power_law_exponent(sizes, cost):
    """The slope b of the least-squares fit log(cost) = a + b log(sizes)."""
    sizes, cost = np.asarray(sizes, dtype=float), np.asarray(cost, dtype=float)
    if sizes.shape != cost.shape or sizes.size < 2 or np.any(sizes <= 0) or np.any(cost <= 0):
        raise ValueError("sizes/cost: need two or more positive pairs of equal length")
    return float(np.polyfit(np.log(sizes), np.log(cost), 1)[0])


def all_single_candidates(mdp):
    """Allowed-action masks of every single-state (psi = 0) and single-action candidate: (X, A, X + A)."""
    X, A = mdp.n_states, mdp.n_actions
    actions = np.ones((X, A, A), dtype=bool)
    actions[:, np.arange(A), np.arange(A)] = False
    return np.concatenate([~chance_forbidden(mdp, np.arange(X), 0.0), actions], axis=2)


def gridworld_ranking(side, n_candidates=None, sparse=False, slip=0.1, horizon=20, algorithm=4, engine="numpy",
                      loiter="goal"):
    """A call that ranks the first ``n_candidates`` (default all X + A) single candidates
    on a ``side`` x ``side`` gridworld by Algorithm 4 (``algorithm=4``, on ``engine``), 3 or 2, or that
    computes Algorithm 1's gradient with them as features (``algorithm=1``). The
    multiply-add counts of :func:`counting_multiply_adds` watch the numpy engine's products."""
    if algorithm not in (1, 2, 3, 4):
        raise ValueError(f"algorithm: must be 1, 2, 3 or 4, got {algorithm!r}")
    g = gridworld(side, side, (0, 0), (side - 1, 0), slip=slip, horizon=horizon, sparse=sparse, loiter=loiter)
    masks = all_single_candidates(g.mdp)[:, :, :n_candidates]
    if algorithm == 4:
        return lambda: log_partition(g.mdp, masks, engine=engine)
    full = np.ones(masks.shape[:2], dtype=bool)
    if algorithm == 1:      # Ziebart's gradient (eq. 2.8): one backup and one forward pass, the candidates as features
        return lambda: expected_features(g.mdp, (~masks).astype(float))
    if algorithm == 2:
        return lambda: constraint_accrual(g.mdp, full, masks)
    return lambda: value_ratio(g.mdp, full, masks)


def gridworld_ranking_work(side, n_candidates=None, sparse=False, slip=0.1, horizon=20, algorithm=4):
    """Multiply-adds (:func:`counting_multiply_adds`) of one :func:`gridworld_ranking` run
    (Algorithm 1, 2, 3 or 4 on the numpy engine)."""
    run = gridworld_ranking(side, n_candidates, sparse, slip, horizon, algorithm)
    with counting_multiply_adds() as tally:
        run()
    return tally["multiply_adds"]


def gridworld_ranking_time(side, n_candidates=None, sparse=False, slip=0.1, horizon=20, algorithm=4, repeats=3):
    """Best wall time (seconds, this machine) of ``repeats`` :func:`gridworld_ranking` runs."""
    return best_time(gridworld_ranking(side, n_candidates, sparse, slip, horizon, algorithm), repeats)
