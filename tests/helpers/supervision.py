"""Simulated supervisors, head-on states and a small closed-form library shared by the chapter 4 tests (and
the bad-input tables' arguments)."""

import functools
import warnings

import numpy as np

from mutual.supervision.exact import exact_counterpart
from mutual.supervision.fit import LibraryEdgeWarning, fit_supervisor
from mutual.supervision.reachability import value_library
from mutual.supervision.supervisor import NoisySupervisor, approach_scenes
from mutual.supervision.value_function import GridSpec


RADIUS = 1.0


def simulated_interventions(library, w_max, mu, sigma, n, seed):
    """A simulated supervisor's interventions; the supervisor judges with the exact value of their model (the
    fit reads exact values where the closed form exists)."""
    rng = np.random.default_rng(seed)
    sup = NoisySupervisor(exact_counterpart(library[library.index_of(w_max)]), mu, sigma)
    states, _ = sup.first_interventions(approach_scenes(n, rng, RADIUS, 7.5), rng)
    return states


def head_on(values, rng):
    """Head-on states (heading at the obstacle centre from a random bearing) with the true robot's exact value
    ``values``: V = sqrt(d^2 + 9) - 4 (R = 3, r = 1)."""
    d, b = np.sqrt((np.asarray(values) + 4) ** 2 - 9), rng.uniform(-np.pi, np.pi, len(values))
    return np.stack([d * np.cos(b), d * np.sin(b), b + np.pi], axis=1)


GRID = GridSpec(8.0, (41, 41, 24))
STATES = np.array([[-3.0, 0.2, 0.0], [-2.5, -0.4, 0.1], [0.5, -3.2, 1.6]])


@functools.lru_cache(maxsize=None)
def small_library():
    return value_library([0.5, 0.75, 1.0, 1.5], 1.0, GRID, method="closed-form")


@functools.lru_cache(maxsize=None)
def small_value_function():
    return small_library()[2]


def small_supervisor(mu=0.5, sigma=0.1):
    return NoisySupervisor(small_value_function(), mu, sigma)


def small_fit():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LibraryEdgeWarning)
        return fit_supervisor(small_library(), STATES)


def case_id(case):
    func = case[0]
    name = getattr(func, "__name__", "call")
    return f"{name}-{case[4][:32]}"


def grid_states(spec):
    xs, ys, ts = spec.coordinate_vectors
    return np.stack(np.meshgrid(xs, ys, ts, indexing="ij"), -1).reshape(-1, 3)
