"""Malformed inputs to every public function of mutual.supervision (issue 13): each must raise the
documented exception (ValueError for bad values and types, FileNotFoundError for a missing file)
with a message that names the argument -- or the file, row and column -- and the reason."""

import functools
import re
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest

from mutual.supervision import explore
from mutual.supervision.control import false_positive_rates, filter_control, safety_controller, simulate_filtered
from mutual.supervision.dubins import (avoid_value_closed_form, check_states, dubins_step, keep_out_margin,
                                       rotate_to_heading, unsafe_reach)
from mutual.supervision.fit import LibraryEdgeWarning, fit_supervisor, recovery_study
from mutual.supervision.reachability import SolverSpec, avoid_value_function, value_library
from mutual.supervision.supervisor import (NoisySupervisor, approach_scenes, collect_interventions, read_interventions,
                                           validate_interventions)
from mutual.supervision.value_function import GridSpec, ValueFunction, ValueLibrary, unsafe_set_contains

GRID = GridSpec(8.0, (41, 41, 24))
STATES = np.array([[-3.0, 0.2, 0.0], [-2.5, -0.4, 0.1], [0.5, -3.2, 1.6]])
HEADER = "participant,trial,time,x,y,theta\n"


@functools.lru_cache(maxsize=None)
def _library():
    return value_library([0.5, 0.75, 1.0, 1.5], 1.0, GRID, method="closed-form")


@functools.lru_cache(maxsize=None)
def _vf():
    return _library()[2]


def _sup(mu=0.5, sigma=0.1):
    return NoisySupervisor(_vf(), mu, sigma)


def _fit():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LibraryEdgeWarning)
        return fit_supervisor(_library(), STATES)


def _csv(text):
    """A reader of a fresh CSV file holding ``text`` (written when the case runs)."""
    def read():
        path = Path(tempfile.mkdtemp(prefix="interventions-")) / "interventions.csv"
        path.write_text(text)
        return read_interventions(path)
    return read


def _value_fn(**change):
    args = dict(w_max=1.0, obstacle_radius=1.0, grid_spec=GRID, values=np.zeros(GRID.shape)) | change
    return ValueFunction(**args)


rng = np.random.default_rng

CASES = [
    # the Dubins car and its closed form (mutual.supervision.dubins)
    (avoid_value_closed_form, ([0.0, 2.0, 0.0], 0.0, 1.0), {}, ValueError, "w_max must be a positive finite"),
    (avoid_value_closed_form, ([0.0, 2.0, 0.0], 1.0, "one"), {}, ValueError, "radius must be a positive finite"),
    (check_states, ([[1.0, 2.0]],), {}, ValueError, "must have shape (n, 3)"),
    (check_states, ([["a", "b", "c"]],), {}, ValueError, "states must be numbers of shape (n, 3)"),
    (dubins_step, (STATES, 0.0, -0.1), {}, ValueError, "dt must be a positive finite"),
    (dubins_step, (STATES, [0.0, 1.0], 0.1), {}, ValueError, "controls must be one turn rate or one per state"),
    (keep_out_margin, ([[np.nan, 0.0, 0.0]], 1.0), {}, ValueError, "states contains NaN"),
    (rotate_to_heading, (STATES,), {"heading": np.inf}, ValueError, "heading must be a finite angle"),
    (unsafe_reach, (1.0, -1.0), {}, ValueError, "radius must be a positive finite"),
    # grids, solver settings, value functions and libraries
    (GridSpec, (8.0, (41, 41, 4.5)), {}, ValueError, "shape must be three integers >= 5"),
    (GridSpec, (np.nan,), {}, ValueError, "half_width must be a positive finite"),
    (SolverSpec, (), {"max_time": -1.0}, ValueError, "max_time must be a positive finite"),
    (_value_fn, (), {"values": np.full(GRID.shape, np.nan)}, ValueError, "values contain"),
    (_value_fn, (), {"method": "exact"}, ValueError, "method must be one of"),
    (value_library, ("1.0", 1.0, GRID), {}, ValueError, "w_maxes must be a non-empty 1-D sequence"),
    (value_library, ([[1.0]], 1.0, GRID), {}, ValueError, "w_maxes must be a non-empty 1-D sequence"),
    (value_library, ([1.0], 1.0, GRID), {"method": "closed-form", "d_max": 0.2}, ValueError,
     "exact only without a disturbance"),
    (value_library, ([1.0], 1.0, GRID), {"method": "spline"}, ValueError, "method must be one of"),
    (value_library, ([1.0], 1.0, GRID), {"solver": "low"}, ValueError, "solver must be a SolverSpec"),
    (value_library, ([1.0], np.inf, GRID), {}, ValueError, "obstacle_radius must be a positive finite"),
    (avoid_value_function, (None, 1.0, GRID), {}, ValueError, "w_max must be a positive finite"),
    (ValueLibrary, ([],), {}, ValueError, "members must be a non-empty list"),
    (lambda: ValueLibrary([_vf(), _vf()]), (), {}, ValueError, "members must have distinct w_max"),
    (lambda: _library().index_of(np.nan), (), {}, ValueError, "w_max must be a finite number"),
    (lambda: _library().index_of(0.6), (), {}, ValueError, "is not in the library"),
    (lambda: unsafe_set_contains(_vf(), "standard"), (), {}, ValueError,
     "must both be mutual.supervision.ValueFunction"),
    (lambda: _vf().theta_slice(0.0, resolution=1), (), {}, ValueError, "resolution must be an integer >= 2"),
    # the noisy idealized supervisor and its scenes
    (lambda: NoisySupervisor(_vf(), "0.5", 0.1), (), {}, ValueError, "mu must be a finite number"),
    (lambda: NoisySupervisor(_vf(), 0.5, np.nan), (), {}, ValueError, "sigma must be a non-negative finite"),
    (approach_scenes, (10, 0, 1.0, 7.5), {}, ValueError, "rng must be a numpy.random.Generator"),
    (lambda: approach_scenes(2.5, rng(0), 1.0, 7.5), (), {}, ValueError, "n must be an integer >= 1"),
    (lambda: approach_scenes(5, rng(0), 1.0, 0.5), (), {}, ValueError, "start_distance=0.5 must exceed"),
    (lambda: _sup().first_interventions(np.full((2, 5, 3), np.nan), rng(0)), (), {}, ValueError,
     "trajectories contain NaN"),
    (lambda: _sup().intervenes(STATES, thresholds=[0.1, 0.2]), (), {}, ValueError, "thresholds must be one number"),
    (lambda: collect_interventions(_sup(mu=-3.0, sigma=0.0), 5, rng(0), 7.5), (), {}, ValueError,
     "the supervisor intervened only 0 times"),
    # the maximum-likelihood fit
    (lambda: fit_supervisor(_library(), STATES, prior="MAP "), (), {}, ValueError, "prior must be 'mle' or 'map'"),
    (fit_supervisor, ("library", STATES), {}, ValueError, "library must be a mutual.supervision.ValueLibrary"),
    (lambda: fit_supervisor(_library(), STATES, reference=_vf()), (), {}, ValueError,
     "reference is used only with prior='map'"),
    (lambda: fit_supervisor(value_library([0.5, 0.75], 1.0, GRID, method="closed-form"), STATES, prior="map"), (), {},
     ValueError, "prior='map' needs reference="),
    (lambda: fit_supervisor(_library(), np.vstack([STATES, [[12.0, 0.0, 0.0]]])), (), {}, ValueError,
     "lie outside the library's grid"),
    (lambda: _fit().level(np.nan), (), {}, ValueError, "k must be a finite number"),
    (lambda: _fit().coverage([[20.0, 0.0, 0.0]]), (), {}, ValueError, "lie outside the library's grid"),
    (lambda: recovery_study(_library(), [(0.75, 0.5)], [10], [0], 7.5), (), {}, ValueError,
     "(w_max, mu, sigma) triples"),
    (lambda: recovery_study(_library(), [(0.75, 0.5, 0.1)], [1], [0], 7.5), (), {}, ValueError,
     "n_values must be integers >= 2"),
    # control on a learned safe set
    (lambda: filter_control(_vf(), STATES, np.nan, 0.0), (), {}, ValueError, "nominal_u contains NaN"),
    (lambda: filter_control(_vf(), STATES, 0.0, [0.0, 1.0]), (), {}, ValueError, "alpha must be one finite number"),
    (lambda: filter_control(_vf(), STATES, 0.0, 0.0, lookahead=-1.0), (), {}, ValueError,
     "lookahead must be a non-negative finite"),
    (lambda: filter_control(_vf(), STATES, 0.0, 0.0, obstacles=[[1.0, 2.0, 3.0]]), (), {}, ValueError,
     "obstacles must be a (k, 2) array"),
    (lambda: filter_control("V", STATES, 0.0, 0.0), (), {}, ValueError, "value_fn must be a mutual.supervision"),
    (lambda: safety_controller(_vf(), alpha=np.inf), (), {}, ValueError, "alpha must be finite"),
    (lambda: false_positive_rates(_sup(), _vf(), [], 10, rng(0), 7.5), (), {}, ValueError,
     "alphas must be a non-empty sequence"),
    (lambda: false_positive_rates(_sup(), _vf(), [0.5], 0, rng(0), 7.5), (), {}, ValueError,
     "n_robots must be an integer >= 1"),
    (lambda: simulate_filtered("controller", STATES, 0.0, 1.0), (), {}, ValueError, "controller must be callable"),
    # the interventions CSV: the file, the row and the column
    (_csv(""), (), {}, ValueError, "interventions.csv: the file is empty"),
    (_csv(HEADER), (), {}, ValueError, "interventions.csv: no data rows after the header"),
    (_csv(HEADER + "P1,0,1.0,-3,0.5,0.1\nP1 ,1,1.2,-3,0.5,0.1\n"), (), {}, ValueError,
     "'P1' (line 2) and 'P1 ' (line 3) differ only in spaces"),
    (_csv(HEADER + "Zo\u00eb,0,1.0,-3,0.5,0.1\nZoe\u0308,1,1.2,-3,0.5,0.1\n"), (), {}, ValueError,
     "differ only in spaces or in how a character is encoded"),
    (_csv("participant,trial,time,x,y\nP01,0,1.0,2.0,3.0\n"), (), {}, ValueError, "missing column 'theta'"),
    (_csv(HEADER + "P01,0,1.0,-3,0.5,0.1\nP01,1,1.2,abc,0.5,0.1\n"), (), {}, ValueError,
     "interventions.csv, line 3, column 'x': 'abc' is not a finite number"),
    (_csv(HEADER + "P01,0,,-3,0.5,0.1\n"), (), {}, ValueError, "interventions.csv, line 2, column 'time': empty"),
    (_csv(HEADER + "P01,1.5,1.0,-3,0.5,0.1\n"), (), {}, ValueError,
     "column 'trial': '1.5' is not a non-negative integer"),
    (_csv(HEADER + "P01,0,-2,-3,0.5,0.1\n"), (), {}, ValueError,
     "column 'time': '-2' is not a non-negative number of seconds"),
    (_csv(HEADER + "P01,0,1,-3,0.5,inf\n"), (), {}, ValueError, "column 'theta': 'inf' is not a finite number"),
    (_csv(HEADER.strip() + ",speed\nP01,0,1,-3,0.5,0.1,3\n"), (), {}, ValueError, "unknown column 'speed'"),
    (_csv(HEADER + "P01,0,1,-3,0.5,0.1,9,9\n"), (), {}, ValueError, "line 2: the row has 8 fields, the header 6"),
    (_csv(HEADER + ",0,1,-3,0.5,0.1\n"), (), {}, ValueError, "column 'participant': empty"),
    (read_interventions, ("/nonexistent/interventions.csv",), {}, FileNotFoundError, "no such interventions file"),
    (validate_interventions, ({"x": [1.0]},), {}, ValueError, "must be a pandas DataFrame"),
    # the Explore view
    (explore.safe_set_view, (), {"w_max": 5.0}, ValueError, "w_max must be a number in [0.25, 3]"),
    (explore.safe_set_view, (), {"n_interventions": 2.5}, ValueError, "n_interventions must be an integer"),
]


def _id(case):
    func = case[0]
    name = getattr(func, "__name__", "call")
    return f"{name}-{case[4][:32]}"


@pytest.mark.parametrize("func, args, kwargs, error, phrase", CASES, ids=[_id(c) for c in CASES])
def test_bad_input_raises_a_clear_error(func, args, kwargs, error, phrase):
    with pytest.raises(error, match=re.escape(phrase)):
        func(*args, **kwargs)


def test_enough_cases():
    assert len(CASES) >= 30
