"""The gather form of the compiled backup (``mutual.constraints.gather``): its segment plan covers every step
with enough states, it equals the numpy backup on a discretized continuous system, and it refuses an MDP
with too many successors."""

import numpy as np
import pytest
import scipy.sparse as sp

from mutual.constraints import MDP, log_partition, rank_candidates
from mutual.constraints.continuous import discretize
from mutual.constraints.continuous.experiments import with_cells
from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.gather import segments

from helpers.continuous import pendulum


@pytest.mark.parametrize("layers", [[1, 5, 20, 60, 100, 100, 100, 100], [7] * 6, [3, 3, 50, 51, 52]])
def test_the_segment_plan_covers_every_step_with_enough_states(layers):
    plan = segments(layers, len(layers))
    assert sum(steps for _, steps in plan) == len(layers)
    t = len(layers)
    for m, steps in plan:                                # last step first
        assert all(m >= layers[s] for s in range(t - steps, t))
        t -= steps
    state_steps = sum(m * steps for m, steps in plan)
    assert state_steps <= max(layers) * len(layers)


def test_the_compiled_gather_backup_equals_the_numpy_backup():
    problem = with_cells(pendulum(), 11)
    S = discretize(problem, scheduler="inline")
    mdp = problem.mdp(S)
    rng = np.random.default_rng(1)
    masks = rng.random((mdp.n_states, mdp.n_actions, 20)) > 0.15
    masks[:, 0, :] = True
    a, b = log_partition(mdp, masks, engine="numpy"), log_partition(mdp, masks, engine="gather")
    assert np.array_equal(np.isfinite(a), np.isfinite(b))
    np.testing.assert_allclose(a[np.isfinite(a)], b[np.isfinite(b)], rtol=1e-12, atol=1e-10)
    demos = sample_demonstrations(mdp, 5, rng=2)
    for x, y in zip(rank_candidates(mdp, demos, ~masks, engine="numpy"), rank_candidates(mdp, demos, ~masks, engine="gather")):
        assert np.array_equal(np.isfinite(x), np.isfinite(y))
        np.testing.assert_allclose(x[np.isfinite(x)], y[np.isfinite(y)], rtol=1e-10, atol=1e-10)


def test_the_gather_engine_refuses_an_mdp_with_too_many_successors():
    X, A = 70, 1
    S = sp.csr_matrix(np.full((X * A, X), 1.0 / X))
    with pytest.raises(ValueError, match="gather backup needs <= 64 successors"):
        log_partition(MDP(S, np.zeros((X, A)), 2), np.ones((X, A), dtype=bool), engine="gather")
