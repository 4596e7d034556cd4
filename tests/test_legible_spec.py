"""The legibility spec (``mutual.motion.spec``): what the TOML loader refuses, table-driven, and what
the solver returns, checked against a second algorithm (the likelihood-ratio minimiser of
Theorem 6.4.2), the QP's active constraint, and the autodiff gradient at the iLQR optimum."""

import numpy as np
import pytest

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
    spec = load_legible_spec(Path(__file__).resolve().parents[1] / "data" / "examples" / "legible.toml")
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
