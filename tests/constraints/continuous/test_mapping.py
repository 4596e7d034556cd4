"""What users get wrong in continuous recordings (``mapping.check_recording``), refused or warned with the reason.

The recordings are made here by integrating the true dynamics forward (the truth a forward recording
follows); each mistake is then made on purpose -- t reversed, degrees, controls in another unit, a
repeated column, too many steps -- and its siblings (rows in reverse order with t, which is fine) pass."""

import warnings

import numpy as np
import pandas as pd
import pytest

from mutual.constraints.continuous import (Grid, Problem, QuadraticReward, integrate, load_system, named_system,
                                           read_recording)
from mutual.constraints.continuous.mapping import check_recording
from mutual.inputs import InputWarning

from helpers.continuous import planar_system

SYSTEM = named_system("pendulum")
GRID = Grid.uniform([-np.pi, -8.0], [np.pi, 8.0], [9, 9], [True, False], SYSTEM.state_names, SYSTEM.state_units)


def _problem(horizon=10):
    return Problem(SYSTEM, GRID, [-3.0, 0.0, 3.0], 0.1, horizon, QuadraticReward([np.pi, 0], [1, 0.1], [0.0], [1, 1]))


def _recorded(n=4, steps=10, seed=0, levels=(-3.0, 0.0, 3.0), noise=0.0):
    """Forward recordings of the pendulum under random controls of ``levels`` (the set's), as the CSV table;
    ``noise``: a random kick of that size (rad/s) to theta_dot after every step."""
    rng = np.random.default_rng(seed)
    x = np.column_stack([rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)])
    rows = []
    for k in range(steps + 1):
        u = rng.choice(levels, size=n)
        for d in range(n):
            rows.append({"demo": f"demo-{d:03d}", "t": round(0.1 * k, 10), "theta": x[d, 0], "theta_dot": x[d, 1],
                         "torque": u[d] if k < steps else np.nan})
        x = GRID.wrap(integrate(SYSTEM, x, u[:, None], 0.1) + [0.0, 1.0] * rng.normal(0, noise, (n, 1)))
    return pd.DataFrame(rows)


def _check(tmp_path, frame=None, text=None, horizon=10):
    path = tmp_path / "t.csv"
    if text is None:
        frame.to_csv(path, index=False)
    else:
        path.write_text(text)
    check_recording(_problem(horizon), read_recording(path, SYSTEM.state_names, SYSTEM.control_names))


GOOD = _recorded()
REFUSED = [  # (case, the recording as a table or CSV text, the horizon, phrases of the error)
    ("t as a time-to-go", GOOD.assign(t=1.0 - GOOD["t"]), 10, ["column 't'", "runs backwards in time"]),
    ("t with the wrong sign", GOOD.assign(t=-GOOD["t"]), 10, ["runs backwards in time", "make t increase"]),
    ("longer than the horizon", GOOD, 6, ["span 10 steps", "more than the horizon T = 6", "[time] horizon"]),
    ("one step longer than the horizon", GOOD, 9, ["more than the horizon T = 9"]),
    ("a repeated column", GOOD.to_csv(index=False).replace("theta_dot", "theta", 1), 10,
     ["line 1", "'theta' appears twice"]),
    ("a name with a trailing space", GOOD.assign(demo=GOOD["demo"].where(GOOD.index != 5, "demo-001 ")), 10,
     ["'demo-001' (line 3)", "'demo-001 ' (line 7)", "differ only in spaces"]),
    ("a comma after every data row", GOOD.to_csv(index=False).replace("\n", ",\n").replace("torque,\n", "torque\n", 1),
     10, ["line 2", "every data row has more fields than the header (6 against 5)"]),
]


@pytest.mark.parametrize("case, data, horizon, phrases", REFUSED, ids=[c[0] for c in REFUSED])
def test_mistakes_in_recordings_are_refused_with_the_reason(case, data, horizon, phrases, tmp_path):
    with pytest.raises(ValueError) as err:
        _check(tmp_path, *((data, None) if isinstance(data, pd.DataFrame) else (None, data)), horizon=horizon)
    assert all(p in str(err.value) for p in phrases), err.value


WARNED = [  # (case, the recording, phrases of the warning)
    ("theta in degrees", GOOD.assign(theta=np.degrees(GOOD["theta"]) * 3), ["column 'theta'", "look like degrees"]),
    ("torque in N cm", GOOD.assign(torque=GOOD["torque"] * 100),
     ["column 'torque'", "recorded 'torque' values lie more than the control set's width outside it ([-3, 3]",
      "check the unit"]),
    ("one torque far outside", GOOD.assign(torque=GOOD["torque"].where(GOOD.index != 9, 40.0)),
     ["line 11, column 'torque'", "1 of 40 recorded"]),
    ("torque in kN m", GOOD.assign(torque=GOOD["torque"] / 1000),
     ["column 'torque'", "do not explain the recorded motion", "'torque' about 1000 times the recorded one"]),
    ("torque with its sign reversed", GOOD.assign(torque=-GOOD["torque"]),
     ["'torque' about -1 times the recorded one (its sign looks reversed)", "check the units, signs and columns"]),
    ("torque with an offset", GOOD.assign(torque=GOOD["torque"] + 1.5),
     ["'torque' about 1 times the recorded one minus 1.5"]),
    ("each torque on the row after its step", GOOD.assign(torque=GOOD.groupby("demo")["torque"].shift(1)),
     ["the steps follow the control recorded one step (dt = 0.1 s) later", "each row's control acts from its t on"]),
    ("each torque on the row before its step", GOOD.assign(torque=GOOD.groupby("demo")["torque"].shift(-1)),
     ["the steps follow the control recorded one step (dt = 0.1 s) earlier"]),
    ("every torque written as 0", GOOD.assign(torque=GOOD["torque"].where(GOOD["torque"].isna(), 0.0)),
     ["every recorded control is 0, but the motion needs others", "were missing values written as 0?"]),
    ("a sample at the box's edge", GOOD.assign(theta_dot=GOOD["theta_dot"].where(GOOD.index != 9, 7.9)),
     ["column 'theta_dot'", "reach the edge of the box, up to 7.9 (high = 8), within a quarter cell",
      "widen [state] low/high"]),
    ("torque normalised to [-1, 1]", GOOD.assign(torque=GOOD["torque"] / 3),
     ["'torque' about 3 times the recorded one"]),
    ("two of four demonstrations in kN m", GOOD.assign(torque=GOOD["torque"].where(GOOD["demo"] > "demo-001",
                                                                                  GOOD["torque"] / 1000)),
     ["demonstrations 'demo-000', 'demo-001' (2 of 4) follow their recorded controls far worse",
      "about 1000 times the recorded one", "other units"]),
    ("one demonstration with its sign reversed", GOOD.assign(torque=GOOD["torque"].where(GOOD["demo"] != "demo-002",
                                                                                         -GOOD["torque"])),
     ["demonstrations 'demo-002' (1 of 4)", "its sign looks reversed"]),
    ("one reversed beside one at rest (which sets no standard)",
     GOOD.assign(torque=GOOD["torque"].where(GOOD["demo"] != "demo-002", -GOOD["torque"]))
     .pipe(lambda f: f.where(f["demo"] != "demo-000", f.assign(theta=0.0, theta_dot=0.0, torque=0.0)))
     .assign(torque=lambda f: f["torque"].where(f["t"] < 1.0)),
     ["demonstrations 'demo-002' (1 of 4)", "its sign looks reversed"]),
    ("torques 0.77 times what acted (a gain the model has 30 % off, or lbf ft)",
     GOOD.assign(torque=GOOD["torque"] * 0.77),
     ["'torque' about 1.299 times the recorded one", "the system's parameters (a heavier system, a weaker actuator) "
      "or the units differ"]),
]


@pytest.mark.parametrize("case, data, phrases", WARNED, ids=[c[0] for c in WARNED])
def test_likely_unit_mistakes_are_warned_about(case, data, phrases, tmp_path):
    with pytest.warns(InputWarning) as record:
        _check(tmp_path, data)
    assert any(all(p in str(w.message) for p in phrases) for w in record), [str(w.message) for w in record]


@pytest.mark.parametrize("case, data", [
    ("as recorded", GOOD),
    ("at rest", GOOD.assign(theta=0.0, theta_dot=0.0, torque=0.0)),
    ("rows in reverse order, t with them", GOOD.iloc[::-1]),
    ("torques slightly beyond the set, as they acted", _recorded(levels=(-4.5, 0.0, 4.5))),
    ("torques recorded with a little noise",
     GOOD.assign(torque=GOOD["torque"] + np.random.default_rng(1).normal(0, 0.1, len(GOOD)))),
    ("motion with process noise as large as a torque's step",
     _recorded(noise=0.3)),
    ("a passive swing with process noise, every torque 0", _recorded(levels=(0.0,), noise=0.1)),
    ("commanded torques recorded, twice the set's, the set's edge acted", GOOD.assign(torque=GOOD["torque"] * 2)),
    ("exactly the horizon", GOOD),
    ("angles that wind past the box by less than a turn", GOOD.assign(theta=GOOD["theta"] + 2 * np.pi)),
])
def test_plausible_recordings_pass_without_a_word(case, data, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("error", InputWarning)
        _check(tmp_path, data)


def test_an_unmodelled_force_in_some_demonstrations_is_not_blamed_on_units(tmp_path):
    """The true damping is 2.5 times the model's: five demonstrations that spin at 7 rad/s stand out from fifteen
    that hang, but what explains them is an offset (the missing friction), not a unit, sign or shift, so nothing is
    said about their controls."""
    truth = named_system("pendulum", {"damping": 0.25})
    grid = Grid.uniform([-np.pi, -14.0], [np.pi, 14.0], [41, 71], [True, False], SYSTEM.state_names, SYSTEM.state_units)
    problem = Problem(SYSTEM, grid, [-3.0, 0.0, 3.0], 0.1, 60, QuadraticReward([np.pi, 0], [1, 0.1], [0.0], [1, 1]))
    rng = np.random.default_rng(2)
    hanging = np.c_[rng.uniform(-1, 1, 15), rng.uniform(-1, 1, 15)]
    x = np.r_[hanging, np.c_[rng.uniform(-1, 1, 5), [7.0, -7.0, 7.0, -7.0, 7.0]]]
    rows = []
    for k in range(61):
        u = np.r_[-x[:15, 1:2] + rng.normal(0, 1, (15, 1)), 3 * np.sign(x[15:, 1:2]) + rng.normal(0, 0.5, (5, 1))]
        u = np.clip(u, -3, 3)
        rows += [{"demo": f"d{d:02d}", "t": round(0.1 * k, 10), "theta": x[d, 0], "theta_dot": x[d, 1],
                  "torque": u[d, 0] if k < 60 else np.nan} for d in range(20)]
        x = grid.wrap(integrate(truth, x, u, 0.1))
    path = tmp_path / "t.csv"
    pd.DataFrame(rows).to_csv(path, index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", InputWarning)
        check_recording(problem, read_recording(path, SYSTEM.state_names, SYSTEM.control_names))


def _unicycle(rate, heading, degrees=False, noise=0.0, dt=2.0, levels=None, noise_xy=0.0):
    """A unicycle recorded every ``dt`` s under random turn rates of [-rate, 0, rate] rad/s (the control set, or
    ``levels``) from headings in [-heading, heading]; its heading column in degrees when ``degrees``, with
    measurement noise of ``noise`` rad (and ``noise_xy`` m on the position)."""
    system = named_system("unicycle", {"speed": 1.0})
    grid = Grid.uniform([-40.0, -40.0, -np.pi], [40.0, 40.0, np.pi], [40, 40, 12], [False, False, True],
                        system.state_names, system.state_units)
    drive = [-rate, 0.0, rate]
    problem = Problem(system, grid, levels or drive, dt, 20, QuadraticReward([0, 0, 0], [1, 1, 0], [0.0], [1, 1, 0]))
    rng = np.random.default_rng(3)
    x, rows = rng.uniform([-1, -1, -heading], [1, 1, heading], (8, 3)), []
    for k in range(11):
        u = rng.choice(drive, size=(8, 1))
        xy = x[:, :2] + noise_xy * rng.normal(size=(8, 2)) if noise_xy else x[:, :2]
        rows += [{"demo": f"d{d}", "t": dt * k, "x": xy[d, 0], "y": xy[d, 1],
                  "heading": (np.degrees if degrees else float)(x[d, 2] + noise * rng.normal()),
                  "turn_rate": u[d, 0] if k < 10 else np.nan}
                 for d in range(8)]
        x = grid.wrap(integrate(system, x, u, dt))
    return problem, pd.DataFrame(rows)


@pytest.mark.parametrize("rate, heading, noise, dt, degrees, warned", [
    (1.5, np.pi, 0, 2, False, False), (1.5, np.pi, 0, 2, True, True), (0.005, 0.1, 0, 2, True, True),
    (0.005, 0.1, 0, 2, False, False), (0.2, 0.2, 0.026, 0.25, False, False)],
    ids=["turning 3 rad a step, radians: silent", "the same in degrees: warned",
         "heading within 8 degrees, in degrees (only its steps tell): warned", "the same in radians: silent",
         "nearly straight with a noisy heading, radians: silent"])
def test_fast_turns_that_the_dynamics_make_are_not_taken_for_degrees(rate, heading, noise, dt, degrees, warned,
                                                                     tmp_path):
    """A step of more than a quarter turn reads as degrees unless the system's own steps turn as fast: a unicycle
    turning 3 rad a step at dt = 2 s does (silent); headings kept within 8 degrees and recorded in degrees stay
    within one turn, but their steps are explained by the dynamics only when read as degrees, so they are named."""
    problem, frame = _unicycle(rate, heading, degrees, noise, dt)
    path = tmp_path / "u.csv"
    frame.to_csv(path, index=False)
    recording = read_recording(path, problem.system.state_names, problem.system.control_names)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always", InputWarning)
        check_recording(problem, recording)
    said = [str(w.message) for w in record if "look like degrees" in str(w.message)]
    assert bool(said) == warned, said


def _said(problem, frame, path):
    """The InputWarnings that checking ``frame`` (written to ``path``) gives."""
    frame.to_csv(path, index=False)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always", InputWarning)
        check_recording(problem, read_recording(path, problem.system.state_names, problem.system.control_names))
    return [str(w.message) for w in record]


@pytest.mark.parametrize("dt, rate, noise", [(2, 1.5, 0), (4, 1.5, 0), (4, 0.75, 0), (5, 0.75, 0), (3, 1.5, 0.3),
                                             (5, 1.5, 0.3)])
def test_a_reversed_turn_rate_is_named_where_a_step_is_far_from_linear_in_it(dt, rate, noise, tmp_path):
    """A unicycle turning up to 7.5 rad a step: the linearised fit of the controls' map misses a reversed sign (it
    finds a factor of 0.04, or -0.12, or with 0.3 m and rad of noise 0.33, which explains the steps roughly), so
    the usual mistakes are tried as they are and the sign is named; the same recording with its controls as
    recorded says nothing."""
    problem, frame = _unicycle(rate, np.pi, dt=dt, noise=noise, noise_xy=noise)
    assert _said(problem, frame, tmp_path / "u.csv") == []
    said = _said(problem, frame.assign(turn_rate=-frame["turn_rate"]), tmp_path / "reversed.csv")
    assert len(said) == 1 and "'turn_rate' about -1 times the recorded one (its sign looks reversed)" in said[0]


def test_turn_rates_in_degrees_per_second_are_named_as_degrees(tmp_path):
    """Turns of 0.05 rad/s recorded as 2.86 deg/s lie within the set's range (up to 3 rad/s), so only the motion
    tells: the map that explains it is pi/180, which is named as degrees."""
    problem, frame = _unicycle(0.05, np.pi, dt=1.0, levels=[-3.0, -0.05, 0.0, 0.05, 3.0])
    assert _said(problem, frame, tmp_path / "u.csv") == []
    said = _said(problem, frame.assign(turn_rate=np.degrees(frame["turn_rate"])), tmp_path / "degrees.csv")
    assert len(said) == 1 and "'turn_rate' about 0.01745 times the recorded one (recorded in degrees where the model " \
                               "takes radians?)" in said[0], said


CAR = """\
system = "car:f"
[state]
names = ["x", "y", "heading"]
units = ["m", "m", "rad"]
low = [-60.0, -60.0, -3.141592653589793]
high = [60.0, 60.0, 3.141592653589793]
cells = [40, 40, 12]
periodic = ["heading"]
[control]
names = ["v", "w"]
units = ["m/s", "rad/s"]
values = [[-1.0, -1.5], [-1.0, 0.0], [-1.0, 1.5], [0.0, 0.0], [1.0, -1.5], [1.0, 0.0], [1.0, 1.5], [0.5, 0.75]]
[time]
dt = 4.0
horizon = 40
[reward]
goal = [0.0, 0.0, 0.0]
"""


@pytest.mark.parametrize("change, phrase", [
    (lambda f: f.assign(v=-f["v"], w=-f["w"]), "'v' about -1 times the recorded one (its sign looks reversed), "
                                                "'w' about -1 times the recorded one (its sign looks reversed)"),
    (lambda f: f.assign(v=-f["w"], w=f["v"]), "'v' about 1 times the recorded 'w', 'w' about -1 times the recorded 'v'")],
    ids=["both signs reversed", "columns exchanged and one reversed"])
def test_two_controls_far_from_linear_with_every_sign_or_an_exchange_and_a_sign_are_named(change, phrase, tmp_path):
    """A car (speed v, turn rate w) recorded every 4 s turns up to 6 rad a step: the linearised fit named 'v' about
    -0.13 and 'w' about 0.57, or nothing; every sign reversed and an exchange with a sign are usual mistakes too."""
    (tmp_path / "car.py").write_text("import numpy as np\ndef f(x, u):\n    h = x[:, 2]\n    return np.stack("
                                     "[u[:, 0] * np.cos(h), u[:, 0] * np.sin(h), u[:, 1]], axis=1)\n")
    (tmp_path / "car.toml").write_text(CAR)
    problem = load_system(tmp_path / "car.toml").problem
    rng = np.random.default_rng(4)
    x, rows = rng.uniform([-1, -1, -np.pi], [1, 1, np.pi], (10, 3)), []
    for k in range(13):
        u = problem.controls[rng.integers(len(problem.controls), size=10)]
        rows += [{"demo": f"d{d}", "t": 4.0 * k, "x": x[d, 0], "y": x[d, 1], "heading": x[d, 2],
                  "v": u[d, 0] if k < 12 else np.nan, "w": u[d, 1] if k < 12 else np.nan} for d in range(10)]
        x = problem.grid.wrap(integrate(problem.system, x, u, 4.0))
    frame = pd.DataFrame(rows)
    assert _said(problem, frame, tmp_path / "car.csv") == []
    said = _said(problem, change(frame), tmp_path / "changed.csv")
    assert len(said) == 1 and phrase in said[0], said


def _planar_recording(problem, n, seed):
    """``n`` demonstrations of 12 steps of the planar system (it moves by u dt) under random controls of the set,
    the zero control where a step would leave the box, as the CSV table."""
    rng = np.random.default_rng(seed)
    x, rows = np.tile([1.5, 1.0], (n, 1)), []
    for k in range(13):
        u = problem.controls[rng.integers(len(problem.controls), size=n)]
        u[problem.grid.outside(x + 0.25 * u)] = 0.0
        rows += [{"demo": f"d{d}", "t": 0.25 * k, "x": x[d, 0], "y": x[d, 1], "vx": u[d, 0], "vy": u[d, 1]}
                 for d in range(n)]
        x = x + 0.25 * u
    return pd.DataFrame(rows)


def test_one_control_of_two_with_its_sign_reversed_or_the_columns_exchanged_are_named(tmp_path):
    """Planar recordings with 'vy' negated in the file: the warning names 'vy' (about -1 times) and not 'vx'
    (whose recorded values explain the steps); then the two columns' names exchanged: both are named."""
    problem = load_system(planar_system(tmp_path)).problem
    frame = _planar_recording(problem, 3, seed=3)
    path = tmp_path / "planar.csv"
    frame.assign(vy=-frame["vy"]).to_csv(path, index=False)
    with pytest.warns(InputWarning) as record:
        check_recording(problem, read_recording(path, problem.system.state_names, problem.system.control_names))
    message = " ".join(str(w.message) for w in record)
    assert "columns 'vx', 'vy'" in message and "'vy' about -1 times the recorded one" in message, message
    assert "'vx' about" not in message, message
    frame = pd.read_csv(path).rename(columns={"vx": "vy", "vy": "vx"})       # the columns' names exchanged
    frame.assign(vx=-frame["vx"]).to_csv(path, index=False)                  # (and the sign put right)
    with pytest.warns(InputWarning) as record:
        check_recording(problem, read_recording(path, problem.system.state_names, problem.system.control_names))
    message = " ".join(str(w.message) for w in record)
    assert "'vx' about 1 times the recorded 'vy', 'vy' about 1 times the recorded 'vx'" in message, message


@pytest.mark.parametrize("change, phrase, units", [
    (lambda f: f.assign(vx=f["vy"], vy=f["vx"]),
     "'vx' about 1 times the recorded 'vy', 'vy' about 1 times the recorded 'vx'", False),
    (lambda f: f.assign(vy=-f["vy"]), "'vy' about -1 times the recorded one", False),
    (lambda f: f.assign(vx=f["vx"] / 100, vy=f["vy"] / 100), "'vx' about 100 times the recorded one", True)],
    ids=["columns exchanged", "one sign reversed", "both controls in another unit (x 1/100)"])
def test_one_demonstration_too_short_to_fit_is_still_named(change, phrase, units, tmp_path):
    """Six planar demonstrations of 12 steps, one of them with a mistake: 12 steps are too few to fit a 2 x 2 map
    and offset (24 are needed), so the usual changes are tried as they are, and the one that explains it is named
    (asking about other units only beside a factor)."""
    problem = load_system(planar_system(tmp_path)).problem
    frame = _planar_recording(problem, 6, seed=5)
    odd = frame["demo"] == "d4"
    frame = pd.concat([frame[~odd], change(frame[odd])]).sort_index()
    path = tmp_path / "planar.csv"
    frame.to_csv(path, index=False)
    with pytest.warns(InputWarning) as record:
        check_recording(problem, read_recording(path, problem.system.state_names, problem.system.control_names))
    said = [str(w.message) for w in record if "follow their recorded controls" in str(w.message)]
    assert len(said) == 1 and "demonstrations 'd4' (1 of 6)" in said[0] and phrase in said[0], said
    assert ("were they recorded in other units?" in said[0]) == units, said

