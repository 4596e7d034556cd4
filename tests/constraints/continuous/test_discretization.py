"""Discretizing continuous dynamics, against independent truth: every row of S is a probability
distribution; for the double integrator -- whose flow is known in closed form -- the transitions
concentrate on the true successor as the cells shrink; the barycentric scheme reproduces the successor
exactly; Monte Carlo and interpolation agree as the resolution grows; Dask gives the same transitions as
one process."""

import numpy as np
import pytest

from mutual.constraints import MDP
from mutual.constraints.continuous import (Grid, Problem, QuadraticReward, discretization as disc_module, discretize,
                                           named_system)
from mutual.constraints.continuous.discretization import kuhn_weights
from mutual.constraints.continuous.experiments import scheme_agreement

from helpers.continuous import pendulum


DI = named_system("double_integrator")


def double_integrator(cells, scheme="sample", samples=16, dt=0.2, box=1.0):
    grid = Grid.uniform([-box, -box], [box, box], [cells, cells], [False, False], DI.state_names, DI.state_units)
    reward = QuadraticReward([0.0, 0.0], [1.0, 0.1], [0.05], [1.0, 1.0])
    return Problem(DI, grid, [-1.0, 0.0, 1.0], dt, 5, reward, scheme=scheme, samples=samples)


def closed_form_successor(x, u, dt):
    """The double integrator's exact flow: p + v dt + u dt^2 / 2, v + u dt."""
    return np.stack([x[:, 0] + x[:, 1] * dt + 0.5 * u * dt ** 2, x[:, 1] + u * dt], axis=1)


@pytest.mark.parametrize("scheme", ["sample", "barycentric"])
@pytest.mark.parametrize("make", [double_integrator, pendulum], ids=["double integrator", "pendulum (periodic)"])
def test_every_row_is_a_probability_distribution(scheme, make):
    problem = make(9, scheme=scheme)
    S = discretize(problem, scheduler="inline")
    assert S.shape == (problem.grid.n_cells * problem.n_actions, problem.grid.n_cells)
    assert S.data.min() > 0
    np.testing.assert_allclose(np.asarray(S.sum(axis=1)).ravel(), 1.0, atol=1e-12)
    MDP(S, np.zeros(S.shape[0]).reshape(problem.grid.n_cells, -1), 3)      # the MDP accepts it


def test_a_three_dimensional_periodic_system_discretizes_too():
    system = named_system("unicycle")
    grid = Grid.uniform([-2, -2, -np.pi], [2, 2, np.pi], [6, 5, 8], [False, False, True], system.state_names,
                        system.state_units)
    problem = Problem(system, grid, [-1.0, 0.0, 1.0], 0.25, 4, QuadraticReward([1, 0, 0], [1, 1, 0], [0.1], [1, 1, 0]))
    for scheme in ("sample", "barycentric"):
        S = discretize(problem.replace(scheme=scheme), scheduler="inline")
        np.testing.assert_allclose(np.asarray(S.sum(axis=1)).ravel(), 1.0, atol=1e-12)


def _interior_stats(problem, radius):
    g, A = problem.grid, problem.n_actions
    S = discretize(problem, scheduler="inline").tocoo()
    centres = g.centers()
    truth = closed_form_successor(np.repeat(centres, A, axis=0), np.tile(problem.controls[:, 0], g.n_cells), problem.dt)
    interior = np.all(np.abs(truth) < 0.7, axis=1)
    dist = np.linalg.norm(centres[S.col] - truth[S.row], axis=1)
    near = np.bincount(S.row, weights=S.data * (dist <= radius), minlength=S.shape[0])
    mean = np.bincount(S.row, weights=S.data * dist, minlength=S.shape[0])
    return near[interior].min(), mean[interior].mean(), g.widths_1d(0)[0]


@pytest.mark.parametrize("scheme", ["sample", "barycentric"])
def test_a_linear_systems_transitions_concentrate_on_the_true_successor_as_cells_shrink(scheme):
    """The mass within 0.2 of the exact successor rises to 1, and the mean distance falls with the cell width."""
    stats = [_interior_stats(double_integrator(n, scheme), 0.2) for n in (10, 20, 40, 80)]
    near, mean, width = (np.array(v) for v in zip(*stats))
    assert near[-1] == pytest.approx(1.0) and near[0] < 1.0
    assert np.all(np.diff(mean) < 0)
    assert np.all(mean <= width)                     # within one cell width of the truth on average
    assert mean[-1] < 0.02


def test_barycentric_weights_reproduce_the_point_exactly():
    """Kuhn-triangulation weights are non-negative, sum to 1 and interpolate linear functions exactly
    (unwrapping the periodic coordinate around the point)."""
    grid = Grid.uniform([-1, -1, -np.pi], [1, 1, np.pi], [5, 6, 8], [False, False, True], "abc", "uuu")
    points = np.random.default_rng(0).uniform([-0.7, -0.7, -np.pi], [0.7, 0.7, np.pi], size=(500, 3))
    vertices, weights = kuhn_weights(grid, points)
    assert weights.min() >= 0 and np.allclose(weights.sum(axis=1), 1.0)
    at = grid.centers()[vertices]
    at[:, :, 2] = points[:, None, 2] + np.mod(at[:, :, 2] - points[:, None, 2] + np.pi, 2 * np.pi) - np.pi
    np.testing.assert_allclose(np.einsum("nk,nkd->nd", weights, at), points, atol=1e-12)


def test_the_barycentric_expected_successor_is_the_exact_successor():
    problem = double_integrator(12, "barycentric")
    g, A = problem.grid, problem.n_actions
    S = discretize(problem, scheduler="inline")
    truth = closed_form_successor(np.repeat(g.centers(), A, axis=0), np.tile(problem.controls[:, 0], g.n_cells), problem.dt)
    inside = np.all(np.abs(truth) < g.centers_1d(0)[-1], axis=1)
    np.testing.assert_allclose((S @ g.centers())[inside], truth[inside], atol=1e-12)


def test_sampling_and_interpolation_agree_as_the_resolution_grows():
    table = scheme_agreement(double_integrator(8), [8, 16, 32, 64])
    gap = table["max |sample - barycentric|"].to_numpy()
    assert np.all(np.diff(gap) < 0) and gap[-1] < 0.25 * gap[0]
    assert np.all(np.diff(table["sample: mean |E x' - x'|"]) < 0)
    assert np.all(table["barycentric: mean |E x' - x'|"] == 0)          # exact up to rounding


def test_dask_gives_the_same_transitions_as_one_process_on_one_or_two_workers(monkeypatch):
    """In this process, on one worker thread, and on two worker processes reached by address."""
    from dask.distributed import LocalCluster
    monkeypatch.setattr(disc_module, "CHUNK_CELLS", 20)           # 81 cells: 5 chunks, each its own seed
    problem = pendulum(9)
    inline = discretize(problem, scheduler="inline")
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        one = discretize(problem, scheduler=cluster.scheduler_address)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        two = discretize(problem, scheduler=cluster.scheduler_address)
    for other in (one, two):
        assert (inline != other).nnz == 0


def test_the_chunks_are_seeded_by_their_number_not_by_where_they_run():
    problem = pendulum(9)
    a = disc_module.chunk_transitions(disc_module.Chunk(3, 20, 40), problem)
    b = disc_module.chunk_transitions(disc_module.Chunk(3, 20, 40), problem)
    c = disc_module.chunk_transitions(disc_module.Chunk(4, 20, 40), problem)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not all(np.array_equal(x, y) for x, y in zip(a, c))
