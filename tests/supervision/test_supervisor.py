"""The noisy idealized supervisor (Sec. 4.3): interventions follow the noise model and the supervisor's level,
exactly n are collected, and the interventions CSV round-trips; what the reader refuses names the file,
the line and the column (tables)."""

import re
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from mutual.supervision.exact import exact_counterpart
from mutual.supervision.reachability import QUICK_GRID
from mutual.supervision.supervisor import (NoisySupervisor, approach_scenes, check_inside, collect_interventions,
                                           intervention_states, read_interventions, validate_interventions,
                                           write_interventions)

from helpers.supervision import STATES, case_id, simulated_interventions, small_supervisor, small_value_function


HEADER = "participant,trial,time,x,y,theta\n"


def _csv(text):
    """A reader of a fresh CSV file holding ``text`` (written when the case runs, removed after)."""
    def read():
        with tempfile.TemporaryDirectory(prefix="interventions-") as folder:
            path = Path(folder) / "interventions.csv"
            path.write_text(text)
            return read_interventions(path)
    return read


rng = np.random.default_rng


CASES = [
    # the noisy idealized supervisor and its scenes
    (lambda: NoisySupervisor(small_value_function(), "0.5", 0.1), (), {}, ValueError, "mu must be a finite number"),
    (lambda: NoisySupervisor(small_value_function(), 0.5, np.nan), (), {}, ValueError, "sigma must be a non-negative finite"),
    (approach_scenes, (10, 0, 1.0, 7.5), {}, ValueError, "rng must be a numpy.random.Generator"),
    (lambda: approach_scenes(2.5, rng(0), 1.0, 7.5), (), {}, ValueError, "n must be an integer >= 1"),
    (lambda: approach_scenes(5, rng(0), 1.0, 0.5), (), {}, ValueError, "start_distance=0.5 must exceed"),
    (lambda: small_supervisor().first_interventions(np.full((2, 5, 3), np.nan), rng(0)), (), {}, ValueError,
     "trajectories contain NaN"),
    (lambda: small_supervisor().intervenes(STATES, thresholds=[0.1, 0.2]), (), {}, ValueError, "thresholds must be one number"),
    (lambda: collect_interventions(small_supervisor(mu=-3.0, sigma=0.0), 5, rng(0), 7.5), (), {}, ValueError,
     "the supervisor intervened only 0 times"),
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
]


@pytest.mark.parametrize("func, args, kwargs, error, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_raises_a_clear_error(func, args, kwargs, error, phrase):
    with pytest.raises(error, match=re.escape(phrase)):
        func(*args, **kwargs)


def test_enough_cases():
    assert len(CASES) >= 23


def test_intervention_values_follow_the_noise_model(library):
    vf = library[library.index_of(0.75)]
    states = simulated_interventions(library, 0.75, 0.5, 0.2, 400, seed=5)
    values = exact_counterpart(vf).interp(states)
    assert len(values) > 380
    assert stats.kstest(values, stats.norm(0.5, 0.2).cdf).pvalue > 1e-3


def test_supervisor_intervenes_at_its_level(library):
    vf = library[library.index_of(1.0)]
    sup = NoisySupervisor(vf, mu=0.5, sigma=0.0)
    states = np.array([[-3.0, 0.0, 0.0], [-7.0, 0.0, 0.0], [3.0, 0.0, 0.0], [30.0, 0.0, 0.0]])
    expected = vf.interp(states, fill_value=np.inf) <= 0.5
    assert np.array_equal(sup.intervenes(states, np.random.default_rng(0)), expected)
    with pytest.raises(ValueError, match="sigma"):
        NoisySupervisor(vf, 0.5, -1.0)
    with pytest.raises(ValueError, match="rng"):
        sup.intervenes(states)


def test_interventions_csv_round_trip_and_validation(tmp_path):
    frame = pd.DataFrame({"participant": ["P01", "P01", "P02"], "trial": [0, 1, 0], "time": [1.5, 2.0, 0.7],
                          "x": [-3.0, -2.0, 1.0], "y": [0.5, 0.0, -2.0], "theta": [0.1, 7.0, -1.0],
                          "obstacle_x": [1.0, 0.0, 0.0]})
    path = write_interventions(frame, tmp_path / "interventions.csv")
    back = read_interventions(path)
    assert list(back.columns) == ["participant", "trial", "time", "x", "y", "theta", "obstacle_x", "obstacle_y"]
    assert back["theta"].between(-np.pi, np.pi).all()
    assert np.allclose(intervention_states(back)[0], [-4.0, 0.5, 0.1])
    for broken, match in [(frame.drop(columns="theta"), "missing column .theta."), (frame.assign(extra=1), "unknown"),
                          (frame.assign(trial=[0, 1.5, 2]), "trial"),
                          (frame.assign(x=[0, np.nan, 1]), "row 1, column 'x': empty"),
                          (frame.assign(time=[-1, 0, 0]), "time")]:
        with pytest.raises(ValueError, match=match):
            validate_interventions(broken)


def test_collect_interventions_returns_exactly_n_and_stops_when_the_supervisor_never_intervenes(library):
    sup = NoisySupervisor(library[library.index_of(1.0)], 0.5, 0.1)
    states = collect_interventions(sup, 25, np.random.default_rng(0), 7.5)
    assert states.shape == (25, 3)
    assert np.allclose(sup.value_fn.interp(states).mean(), 0.5, atol=0.1)
    never = NoisySupervisor(library[library.index_of(1.0)], -5.0, 0.0)
    with pytest.raises(ValueError, match="intervened only 0 times in 100 scenes"):
        collect_interventions(never, 2, np.random.default_rng(0), 7.5)


def test_interventions_file_errors_name_the_file_row_and_column(tmp_path):
    path = tmp_path / "mine.csv"
    path.write_text("participant,trial,time,x,y,theta\nP01,0,1.0,-3,0.5,0.1\n\nP01,1,1.5,-2,oops,0.1\n")
    with pytest.raises(ValueError) as err:
        read_interventions(path)
    message = str(err.value)
    assert message.startswith(f"{path}, line 4, column 'y'")
    assert "'oops'" in message


OBSTACLE_HEADER = "participant,trial,time,x,y,theta,obstacle_x,obstacle_y\n"


OUTSIDE = [  # (rows after the header, the line named, what the message shows)
    ("P1,0,1,-3,0,0,0,0\nP1,0,2,10,2,0,0,0\n", 3, "x = 10, y = 2 lies outside"),
    ("P1,0,1,52,2,0,40,0\nP1,0,2,-3,0,0,0,0\n", 2, "x = 52, y = 2 lies outside .* around the obstacle at \\(40, 0\\)"),
    ("\nP1,0,1,-3,0,0,0,0\n\nP1,0,2,0,-9,0,0,0\n", 5, "x = 0, y = -9 lies outside"),   # blank lines count
    ("P1,0,1,-3,0,0,0,0\nP1,0,2,0,-9,0,0,0\nP1,0,3,9,9,0,0,0\n", 3, r"x = 0, y = -9 .*\(1 more rows like it\)"),
    ("P1,0,1,1e308,0,0,-1e308,0\n", 2, "x = 1e\\+308, y = 0 lies outside"),
]


@pytest.mark.parametrize("rows, line, shown", OUTSIDE)
def test_an_intervention_outside_the_grid_names_its_line_in_the_files_coordinates(tmp_path, rows, line, shown):
    path = tmp_path / "interventions.csv"
    path.write_text(OBSTACLE_HEADER + rows)
    frame = read_interventions(path)
    with pytest.raises(ValueError, match=f"{path}, line {line}: the intervention at {shown}"):
        check_inside(frame, QUICK_GRID.half_width, path)


@pytest.mark.parametrize("rows", ["P1,0,1,8,-8,0,0,0\n", "P1,0,1,47,7.5,0,40,0\n", "P1,0,1,-7.99,3,9,0,0\n"])
def test_interventions_inside_the_grid_pass(tmp_path, rows):
    path = tmp_path / "interventions.csv"
    path.write_text(OBSTACLE_HEADER + rows)
    check_inside(read_interventions(path), QUICK_GRID.half_width, path)
