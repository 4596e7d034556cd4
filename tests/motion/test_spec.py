"""The legibility spec (``mutual.motion.spec``): what the TOML loader refuses, table-driven, naming the key
or the file; what the solver returns, checked against a second algorithm (the likelihood-ratio minimiser of
Theorem 6.4.2), the QP's active constraint, the autodiff gradient at the iLQR optimum and the closed-form
motion at 2000 steps; specs beyond what can be solved refused naming the key."""

import numpy as np
import pytest

from mutual.motion import legible as leg
from mutual.motion.spec import LegibleSpec, legible_spec, load_legible_spec, solve_legible


BASE = {"start": [0.0, 0.0], "goal": [1.0, 1.0], "distractors": [[-1.0, 1.0]], "horizon": 1.0, "steps": 20,
        "alpha": 1.0}


def spec_with(**changes):
    d = {**BASE, **changes}
    return {k: v for k, v in d.items() if v is not None}


BAD = [
    (spec_with(goal=None), "key 'goal': missing"),
    (spec_with(start=None), "key 'start': missing"),
    (spec_with(distractors=None), "key 'distractors': missing"),
    (spec_with(horizon=None), "key 'horizon': missing"),
    (spec_with(colour="red"), "key 'colour': unknown key"),
    (spec_with(dynamics="car"), "key 'dynamics': must be one of"),
    (spec_with(start=[0.0]), "key 'start': must be a list of 2 numbers"),
    (spec_with(start=[0.0, "a"]), "key 'start'"),
    (spec_with(start=[0.0, float("nan")]), "key 'start'"),
    (spec_with(goal=[1.0, 1.0, 0.0]), "key 'goal'"),
    (spec_with(distractors=[]), "key 'distractors': must be a non-empty list"),
    (spec_with(distractors=[1.0, 2.0]), "key 'distractors[0]'"),
    (spec_with(distractors=[[1.0, 1.0]]), "equals the goal"),
    (spec_with(horizon=0.0), "key 'horizon': must be a positive finite number"),
    (spec_with(horizon=float("inf")), "key 'horizon': must be a positive finite number"),
    (spec_with(horizon=True), "key 'horizon': must be a positive finite number"),
    (spec_with(steps=0), "key 'steps'"),
    (spec_with(steps=10.0), "key 'steps'"),
    (spec_with(steps=None), "key 'steps'"),
    (spec_with(alpha=0.0), "key 'alpha': must be a positive finite number"),
    (spec_with(alpha=-1.0), "key 'alpha': must be a positive finite number"),
    (spec_with(alpha=None), "give exactly one of alpha"),
    (spec_with(eta=-1.0), "give exactly one of alpha"),
    (spec_with(terminal_weight=0.0), "key 'terminal_weight'"),
    (spec_with(effort_weight=-2.0), "key 'effort_weight'"),
    (spec_with(speed=3.0), "key 'speed': only for dynamics"),
    (spec_with(dynamics="dubins"), "key 'start': must be a list of 3 numbers"),
    (spec_with(dynamics="dubins", start=[0, 0, 0], alpha=None, eta=-1.0), "key 'eta'"),
    (spec_with(anticipation=3), "key 'anticipation': must be a table"),
    (spec_with(anticipation={"alpha_start": 1.0}), "key 'anticipation.alpha_end': missing"),
    (spec_with(anticipation={"alpha_start": 2.0, "alpha_end": 1.0}), "must be >= alpha_start"),
    (spec_with(anticipation={"alpha_start": 1.0, "alpha_end": 2.0, "every": 0}), "anticipation.every"),
    (spec_with(anticipation={"alpha_start": 1.0, "alpha_end": 2.0, "pace": 1}), "anticipation.pace"),
    (spec_with(dynamics="dubins", start=[0, 0, 0], anticipation={"alpha_start": 1.0, "alpha_end": 2.0}),
     "key 'anticipation': needs"),
]


@pytest.mark.parametrize("mapping, phrase", BAD)
def test_bad_specs_are_refused_naming_the_key(mapping, phrase):
    with pytest.raises(ValueError) as err:
        legible_spec(mapping, "my.toml")
    assert str(err.value).startswith("my.toml: ") and phrase in str(err.value)


@pytest.mark.parametrize("text, phrase", [
    ("start = [0, 0\n", "not valid TOML"),
    ("", "key 'start': missing"),
    ("start = [0, 0]\nstart = [1, 1]\n", "not valid TOML"),
])
def test_bad_toml_files_name_the_file(tmp_path, text, phrase):
    path = tmp_path / "spec.toml"
    path.write_text(text)
    with pytest.raises(ValueError) as err:
        load_legible_spec(path)
    assert str(path) in str(err.value) and phrase in str(err.value)


def test_not_utf8_is_refused(tmp_path):
    path = tmp_path / "spec.toml"
    path.write_bytes(b"start = \xff\xfe\n")
    with pytest.raises(ValueError, match="not valid TOML"):
        load_legible_spec(path)


def test_the_example_spec_loads_with_its_documented_defaults():
    from pathlib import Path
    spec = load_legible_spec(Path(__file__).resolve().parents[2] / "data" / "examples" / "legible.toml")
    assert spec.method == "receding-horizon" and spec.anticipation == (0.25, 4.0, 1)
    assert legible_spec(BASE).terminal_weight == 1.0 and legible_spec(BASE).effort_weight == 1.0


def test_lqr_equals_the_likelihood_ratio_minimiser():
    """Theorem 6.4.2 by a second algorithm: the minimiser of log Lambda + alpha J1 from the two
    Gaussians' means and precisions equals the Riccati solution of (1 + alpha) J1 - J0."""
    from mutual.motion.legible import reaching_cost, single_integrator
    from mutual.motion.observer import likelihood_ratio_minimiser
    spec = legible_spec(spec_with(alpha=0.7, goal=[2.0, 1.0], terminal_weight=3.0))
    out = solve_legible(spec)
    dyn = single_integrator(2, spec.dt)
    J1 = reaching_cost(spec.goal, spec.dt, 3.0, 1.0)
    J0 = reaching_cost(spec.distractors[0], spec.dt, 3.0, 1.0)
    u = likelihood_ratio_minimiser(dyn, J0, J1, np.zeros(2), spec.steps, alpha=0.7)
    assert np.allclose(out["legible"][1], u, atol=1e-8)
    assert out["evidence"]["legible"][0] < out["evidence"]["predictable"][0]


def test_several_distractors_use_their_mean_cost():
    """Two distractors placed symmetrically about the line to the goal cancel sideways, so the legible
    motion goes straight at the goal (beyond it: exaggeration), unlike with either distractor alone."""
    both = solve_legible(legible_spec(spec_with(goal=[0.0, 2.0], distractors=[[-2.0, 0.0], [2.0, 0.0]])))
    xs = both["legible"][0]
    assert np.allclose(xs[:, 0], 0.0, atol=1e-10) and xs[-1, 1] > 1.0
    left = solve_legible(legible_spec(spec_with(goal=[0.0, 2.0], distractors=[[-2.0, 0.0]])))
    assert left["legible"][0][-1, 0] > 0.1        # pushed away from the single distractor


def test_qp_meets_its_evidence_bound():
    spec = legible_spec(spec_with(alpha=None, eta=-3.0, distractors=[[-1.0, 1.0], [0.0, -1.0]]))
    out = solve_legible(spec)
    from mutual.motion.legible import reaching_cost
    J1 = reaching_cost(spec.goal, spec.dt)
    xs, us = out["legible"]
    gaps = [J1.value(xs, us) - reaching_cost(g, spec.dt).value(xs, us) for g in spec.distractors]
    assert max(gaps) == pytest.approx(-3.0, abs=1e-5)      # the binding constraint J1 - J0_i <= eta
    assert all(g <= -3.0 + 1e-5 for g in gaps) and out["method"] == "qp"


def test_receding_horizon_raises_alpha_over_the_horizon():
    out = solve_legible(legible_spec(spec_with(anticipation={"alpha_start": 0.5, "alpha_end": 4.0, "every": 5})))
    alphas = out["alphas"]
    assert alphas[0] == pytest.approx(0.5) and np.all(np.diff(alphas) >= 0) and alphas[-1] < 4.0


def test_dubins_legible_is_a_stationary_point_and_exaggerates():
    from mutual.motion import spec_dubins as module
    from mutual.motion.trajopt import trajectory_cost_grad
    spec = legible_spec({"dynamics": "dubins", "start": [0.0, 0.0, np.pi / 2], "goal": [1.5, 2.5],
                         "distractors": [[-1.5, 2.5]], "horizon": 1.0, "steps": 30, "alpha": 1.0,
                         "terminal_weight": 10.0, "effort_weight": 0.1})
    out = solve_legible(spec)
    xs, us = out["legible"]
    params = module.params(spec, 2 * 10.0, 10.0, 1.0 * 0.1)
    value, grad = trajectory_cost_grad(module.step, module.running, module.terminal,
                                       np.array(spec.start), us, params)
    assert np.abs(grad).max() <= 1e-6 * (1 + abs(value))
    # the legible end point lies farther right, away from the distractor, than the predictable one
    assert xs[-1, 0] > out["predictable"][0][-1, 0] + 0.3
    assert out["evidence"]["legible"][0] < out["evidence"]["predictable"][0]


def test_solve_refuses_what_is_not_a_spec():
    with pytest.raises(ValueError, match="LegibleSpec"):
        solve_legible(BASE)
    assert isinstance(legible_spec(BASE), LegibleSpec)


G0, G1 = (-1.0, 1.0), (1.0, 1.0)


# ---- legibility specs (class: refused naming the key / answered) ----------------------------------------
REACH_BASE = {"start": [0.0, 0.0], "goal": [1.0, 1.0], "distractors": [[-1.0, 1.0]], "horizon": 1.0, "steps": 20,
        "alpha": 1.0}


QP = {"alpha": None, "goal": [0.0, 1.0], "distractors": [[-1.0, 1.0], [1.0, 1.0]]}
DUBINS = {"dynamics": "dubins", "start": [0.0, 0.0, 1.5]}
ANTICIPATION = {"anticipation": {"alpha_start": 0.5, "alpha_end": 2.0}}
HUGE = 10 ** 400                       # a TOML integer that no float holds: OverflowError before


def spec(**changes):
    d = {**REACH_BASE, **changes}
    return {k: v for k, v in d.items() if v is not None}


def with_anticipation(**changes):
    return spec(anticipation={**ANTICIPATION["anticipation"], **changes})


REFUSED = [
    # numbers beyond what the solvers can serve
    ("start at 1e300", spec(start=[1e300, 0.0]), "start"),
    ("steps 1e8", spec(steps=100_000_000), "steps"),
    ("eta infeasible", spec(**QP, eta=-100.0), "eta"),
    # magnitudes: 1e-300 and 1e300 in each kind of number
    ("goal 1e300", spec(goal=[1e300, 1.0]), "goal"),
    ("distractor 1e51", spec(distractors=[[-1.0, 1.0], [0.0, -1e51]]), "distractors[1]"),
    ("goal and distractor 1e-6 apart at 1e6", spec(goal=[1e6, 1e6], distractors=[[1e6, 1e6 + 1e-6]]),
     "distractors[0]"),
    ("start 1e40 with goals 2 apart", spec(start=[1e40, 0.0]), "distractors[0]"),
    ("dt 1e-300 (tiny horizon)", spec(horizon=1e-300), "horizon"),
    ("dt 1e-51 (10000 steps)", spec(horizon=1e-47, steps=10_000), "horizon"),
    ("dt 1e300", spec(horizon=1e300), "horizon"),
    ("alpha 1e-10", spec(alpha=1e-10), "alpha"),
    ("alpha 1e60", spec(alpha=1e60), "alpha"),
    ("alpha_start 1e-9", with_anticipation(alpha_start=1e-9), "anticipation.alpha_start"),
    ("terminal_weight 1e-60", spec(terminal_weight=1e-60), "terminal_weight"),
    ("effort_weight 1e300", spec(effort_weight=1e300), "effort_weight"),
    ("eta 1e60", spec(**QP, eta=1e60), "eta"),
    ("eta -1e40, one distractor", spec(alpha=None, eta=-1e40), "eta"),
    ("speed 1e-300", spec(**DUBINS, speed=1e-300), "speed"),
    ("heading 1e10 rad", spec(dynamics="dubins", start=[0.0, 0.0, 1e10]), "start"),
    ("car reach 3, goals 1.4e40 away", spec(**DUBINS, goal=[1e40, 1e40], distractors=[[-1e40, 1e40]]), "goal"),
    ("car reach 1e40, goals 1.4 away", spec(**DUBINS, speed=1e40), "speed"),
    # NaN and infinity in each key
    *[(f"{bad} in {key}", spec(**{key: value}), name) for bad, v in (("nan", float("nan")), ("inf", float("inf")))
      for key, value, name in (("start", [v, 0.0], "start"), ("goal", [1.0, v], "goal"),
                               ("distractors", [[-1.0, 1.0], [v, 0.0]], "distractors[1]"), ("horizon", v, "horizon"),
                               ("steps", v, "steps"), ("alpha", v, "alpha"), ("terminal_weight", v, "terminal_weight"),
                               ("effort_weight", v, "effort_weight"))],
    ("nan in eta", spec(**QP, eta=float("nan")), "eta"),
    ("-inf in eta", spec(**QP, eta=-float("inf")), "eta"),
    ("nan in speed", spec(**DUBINS, speed=float("nan")), "speed"),
    ("inf in alpha_end", with_anticipation(alpha_end=float("inf")), "anticipation.alpha_end"),
    ("nan in every", with_anticipation(every=float("nan")), "anticipation.every"),
    # integers no float holds (OverflowError before)
    ("huge integer in start", spec(start=[HUGE, 0]), "start"),
    ("huge integer in horizon", spec(horizon=HUGE), "horizon"),
    ("huge integer in alpha", spec(alpha=HUGE), "alpha"),
    ("huge integer in eta", spec(**QP, eta=-HUGE), "eta"),
    ("huge integer in terminal_weight", spec(terminal_weight=HUGE), "terminal_weight"),
    ("huge integer in alpha_end", with_anticipation(alpha_end=HUGE), "anticipation.alpha_end"),
    ("huge integer in steps", spec(steps=HUGE), "steps"),
    ("huge integer in every", with_anticipation(every=HUGE), "anticipation.every"),
    # steps
    ("steps 0", spec(steps=0), "steps"),
    ("steps -5", spec(steps=-5), "steps"),
    ("steps 10001", spec(steps=10_001), "steps"),
    # goals equal to distractors
    ("distractor equal to the goal", spec(distractors=[[2.0, 2.0], [1.0, 1.0]]), "distractors[1]"),
]


@pytest.mark.parametrize("mapping, key", [c[1:] for c in REFUSED], ids=[c[0] for c in REFUSED])
def test_specs_beyond_what_can_be_solved_are_refused_naming_the_key(mapping, key):
    with pytest.raises(ValueError) as err:
        solve_legible(legible_spec(mapping, "s.toml"))
    message = str(err.value)
    assert f"key '{key}'" in message, message
    assert len(message) < 600 and "\n" not in message
    if key == "steps" and mapping["steps"] == 100_000_000:
        assert "GiB" in message                          # the memory it would need


def test_a_qp_bound_no_motion_meets_is_explained():
    message = ""
    try:
        solve_legible(legible_spec(spec(**QP, eta=-100.0)))
    except ValueError as err:
        message = str(err)
    assert "smallest bound any end point meets is -1" in message


ANSWERED = [
    ("1 step", spec(steps=1)),
    ("1 step, anticipation", spec(steps=1, **ANTICIPATION)),
    ("1 step, QP", spec(steps=1, **QP, eta=-0.5)),
    ("2000 steps (hung > 300 s)", spec(steps=2000)),
    ("2000 steps, anticipation", spec(steps=2000, **ANTICIPATION)),
    ("QP with a bound just above the smallest", spec(**{**QP, "distractors": [[-1.0, 1.0], [2.0, 1.0], [0.0, -1.0]]},
                                                     eta=-2.0 + 1e-6)),
    ("QP with a loose bound", spec(**QP, eta=1e40)),
    ("duplicate distractors", spec(distractors=[[-1.0, 1.0], [-1.0, 1.0]])),
    ("distractor at the start", spec(distractors=[[0.0, 0.0]])),
    ("goal at the start", spec(goal=[0.0, 0.0], distractors=[[1.0, 0.0]])),
    ("mixed 1e40 and 1e-40 coordinates", spec(start=[1e-40, 1e40], goal=[1e40, 1e-40], distractors=[[-1e40, 1e-40]])),
    ("scale 1e-300", spec(goal=[1e-300, 1e-300], distractors=[[-1e-300, 1e-300]])),
]


@pytest.mark.parametrize("mapping", [c[1] for c in ANSWERED], ids=[c[0] for c in ANSWERED])
def test_specs_within_reach_are_answered_with_finite_numbers(mapping):
    out = solve_legible(legible_spec(mapping))
    for xs, us in (out["legible"], out["predictable"]):
        assert np.all(np.isfinite(xs)) and np.all(np.isfinite(us))
    assert all(np.isfinite(v) for vs in out["evidence"].values() for v in vs)


@pytest.mark.parametrize("scale", [1e-100, 1e-300, 1e40])
def test_the_solution_scales_with_the_positions(scale):
    """x' = u with eq. (6.17) is scale-covariant: positions times s give the motion times s and the evidence
    times s^2 (where s^2 is representable; at 1e-300 it underflows to within 1e-300 of zero)."""
    unit = solve_legible(legible_spec(spec(goal=[1.0, 2.0], distractors=[[-1.0, 1.5]])))
    scaled = solve_legible(legible_spec(spec(goal=[scale, 2 * scale], distractors=[[-scale, 1.5 * scale]])))
    for name in ("legible", "predictable"):
        np.testing.assert_allclose(scaled[name][0] / scale, unit[name][0], rtol=1e-12, atol=1e-12)
        e, e1 = np.array(scaled["evidence"][name]), np.array(unit["evidence"][name])
        if scale ** 2 > 1e-290:
            np.testing.assert_allclose(e / scale ** 2, e1, rtol=1e-9)
        else:
            assert np.all(np.abs(e) <= 1e-290)


def test_2000_steps_give_the_closed_form_motion_and_evidence():
    """x' = u with eq. (6.17), T = 1, unit weights: the legible end point is (g1 + (g1 - g0)/alpha)/2, and
    log Lambda = J1 - J0 along the motion (the goals are symmetric about the start, so J0* = J1*)."""
    out = solve_legible(legible_spec(spec(steps=2000, alpha=0.5)))
    xs, us = out["legible"]
    g0, g1 = np.array(G0), np.array(G1)
    np.testing.assert_allclose(xs[-1], (g1 + (g1 - g0) / 0.5) / 2, rtol=1e-9)
    J1_, J0_ = leg.reaching_cost(G1, 1.0 / 2000), leg.reaching_cost(G0, 1.0 / 2000)
    assert out["evidence"]["legible"][0] == pytest.approx(J1_.value(xs, us) - J0_.value(xs, us), rel=1e-9)


DUBINS = {**BASE, "dynamics": "dubins", "start": [0.0, 0.0, 0.0]}


@pytest.mark.parametrize("heading, warned", [(90.0, True), (-180.0, True), (270.0, True), (12.0, True),
                                             (1.5707963, False), (-3.14159, False), (6.0, False)])
def test_a_heading_in_degrees_is_warned_about_naming_the_key(heading, warned):
    """A start heading more than a turn outside [-pi, pi] reads as degrees (90 is 90 rad, about 2.04 rad after
    wrapping): warned, naming the key; headings in radians pass silently."""
    import warnings
    from mutual.inputs import InputWarning
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        legible_spec({**DUBINS, "start": [0.0, 0.0, heading]}, "spec.toml")
    messages = [str(w.message) for w in seen if issubclass(w.category, InputWarning)]
    assert bool(messages) == warned, messages
    if warned:
        assert "key 'start'" in messages[0] and "degrees" in messages[0]
