"""Numbers that stay numbers and bounded work on the motion side (issue 22 §2-3), table-driven: the
legibility log-likelihood ratio and the observer's posterior at controls far beyond where their squares
are representable, checked against exact rational arithmetic; what float64 cannot represent refused
with a named error; sizes refused before anything is allocated; and legibility specs whose numbers the
solvers cannot serve refused naming the key, never answered with NaN, infinity or null."""

import json
import tracemalloc
from fractions import Fraction

import numpy as np
import pytest

from mutual.cli import main
from mutual.motion import belief, observer
from mutual.motion import legible as leg
from mutual.motion.chain import NotRepresentable, log_ratio_prefix, lq_chains
from mutual.motion.legible import anticipation, qp
from mutual.motion.spec import legible_spec, solve_legible

DT, N = 0.1, 10
DYN = leg.single_integrator(2, DT)
G0, G1 = (-1.0, 1.0), (1.0, 1.0)
J0, J1 = leg.reaching_cost(G0, DT), leg.reaching_cost(G1, DT)
X0 = np.zeros(2)


def controls(scale, first=None):
    us = np.full((N, 2), scale)
    if first is not None:
        us[0] = first
    return us


def exact_log_lambda(us):
    """log Lambda = J1(u) - J0(u) exactly: the hypotheses share their quadratic part and the goals are
    symmetric about the start (so J0* = J1*), and the effort cancels; p = x0 + dt sum u in rationals."""
    p = [sum((Fraction(DT) * Fraction(u) for u in us[:, i]), Fraction(0)) for i in range(2)]
    d1 = sum((pi - Fraction(g)) ** 2 for pi, g in zip(p, G1))
    d0 = sum((pi - Fraction(g)) ** 2 for pi, g in zip(p, G0))
    return float(d1 - d0)


# ---- the log-likelihood ratio: exact where the squares are not (class: answered, exact) ------------------
RATIO = [1e16, 1e20, 1e200, 1e300, -1e16, 3.7e-3, 1e-170, 1e-300]
RATIO_MIXED = [(1e-200, 1e200), (1.0, 1e300), (1e200, -1e200)]


@pytest.mark.parametrize("us", [controls(c) for c in RATIO] + [controls(a, b) for a, b in RATIO_MIXED],
                         ids=[f"{c:g}" for c in RATIO] + [f"{b:g} then {a:g}" for a, b in RATIO_MIXED])
def test_log_likelihood_ratio_is_exact_at_any_scale(us):
    """1e16 gave -7.2e16 (truth -4e16), 1e20 gave 0 and 1e200 NaN: relative 1e-12 above 1 nat, absolute below."""
    truth = exact_log_lambda(us)
    got = observer.log_likelihood_ratio(DYN, J0, J1, X0, us)
    assert abs(got - truth) <= 1e-12 * max(1.0, abs(truth))
    prefix = belief.posterior_over_time(us, *lq_chains(DYN, [J0, J1], X0, N))
    logit_truth = -truth                                 # P(H1 | u) = logistic(-log Lambda), equal priors
    assert np.all(np.isfinite(prefix)) and prefix[-1] == pytest.approx(0.5 * (1 + np.tanh(0.5 * logit_truth)),
                                                                       abs=1e-12)


@pytest.mark.parametrize("scale", [1e16, 1e200, 1e-300])
def test_posterior_over_several_hypotheses_is_a_distribution(scale):
    J2 = leg.reaching_cost((0.0, -1.0), DT)
    post = observer.posterior_over_time(DYN, [J0, J1, J2], X0, controls(scale))
    assert np.all(np.isfinite(post)) and np.allclose(post.sum(axis=1), 1.0, atol=1e-12)
    if scale > 1:                                        # far right and up: the goal (1, 1) wins outright
        assert post[-1, 1] == 1.0


@pytest.mark.parametrize("scale", [1e16, 1e200])
def test_dense_pairs_give_the_same_posterior(scale):
    """belief.posterior_over_time with (mean, precision) pairs: the same stable difference of squares."""
    chains = lq_chains(DYN, [J0, J1], X0, N)
    pairs = [tuple(g) for g in chains]
    np.testing.assert_allclose(belief.posterior_over_time(controls(scale), *pairs),
                               belief.posterior_over_time(controls(scale), *chains), atol=1e-12)


def test_a_single_log_density_is_exact_where_representable():
    """log P(u | H) at controls of 1e16 (about -4e32) against the Gaussian density written out densely."""
    us = controls(1e16)
    mean, H = belief.lq_gaussian(DYN, J0, X0, N)
    e = us.reshape(-1) - mean.reshape(-1)
    truth = -0.5 * e @ H @ e + 0.5 * np.linalg.slogdet(H)[1] - N * np.log(2 * np.pi)
    assert observer.log_boltzmann(DYN, J0, X0, us) == pytest.approx(truth, rel=1e-12)


# ---- what float64 cannot represent is refused (class: refused, named) ---------------------------------
UNREPRESENTABLE = [
    (observer.log_boltzmann, (DYN, J0, X0, controls(1e200)), "us: log P(u | H)"),
    (observer.log_boltzmann_prefix, (DYN, J1, X0, controls(-1e300)), "us: log P(u | H)"),
    (belief.gaussian_prefix_loglik, (controls(1e170), belief.lq_gaussian(DYN, J0, X0, N)), "beyond float64"),
]


@pytest.mark.parametrize("fn, args, phrase", UNREPRESENTABLE, ids=[c[0].__name__ for c in UNREPRESENTABLE])
def test_what_float64_cannot_represent_is_refused(fn, args, phrase):
    with pytest.raises(NotRepresentable, match=phrase.replace("(", r"\(").replace(")", r"\)")):
        fn(*args)


# ---- sizes checked before allocating (class: refused, with the memory) --------------------------------
BIG = 10 ** 6
SIZES = [
    (observer.lifted_cost, (DYN, J0, X0, BIG), {}, "N = 1000000 steps"),
    (observer.likelihood_ratio_minimiser, (DYN, J0, J1, X0, BIG), {}, "GiB"),
    (observer.sample_boltzmann, (DYN, J0, X0, BIG, 1, np.random.default_rng(0)), {}, "GiB"),
    (observer.batch_costs, (DYN, J0, X0, np.zeros((1, BIG, 2))), {}, "GiB"),
    (anticipation.weighted_evidence_optimum, (DYN, J1, J0, X0, BIG), {}, "GiB"),
    (qp.multi_distractor_qp, (DYN, J1, [J0], X0, BIG, -1.0), {"formulation": "dense"}, "GiB"),
]


@pytest.mark.parametrize("fn, args, kwargs, phrase", SIZES, ids=[c[0].__name__ for c in SIZES])
def test_dense_sizes_are_refused_before_allocating(fn, args, kwargs, phrase):
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=phrase) as err:
            fn(*args, **kwargs)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert "would need" in str(err.value) and peak < 100 * 2 ** 20


def test_banded_forms_serve_a_long_horizon_and_refuse_its_dense_matrix():
    """12 000 steps: the observer's evidence for the goal's own optimal motion equals J1 - J0 exactly (the goals
    are symmetric about the start), while the dense precision (4.3 GiB) is refused."""
    n_steps = 12_000
    dyn = leg.single_integrator(2, 1.0 / n_steps)
    g0, g1 = lq_chains(dyn, [leg.reaching_cost(G0, 1.0 / n_steps), leg.reaching_cost(G1, 1.0 / n_steps)], X0, n_steps)
    p = [sum((Fraction(1, n_steps) * Fraction(u) for u in g1.mean[:, i]), Fraction(0)) for i in range(2)]
    truth = float(sum((pi - Fraction(g)) ** 2 for pi, g in zip(p, G1)) - sum((pi - Fraction(g)) ** 2
                                                                            for pi, g in zip(p, G0)))
    assert log_ratio_prefix(g1.mean, g0, g1)[-1] == pytest.approx(truth, rel=1e-12)
    with pytest.raises(ValueError, match="would need"):
        g0.precision()


def test_receding_horizon_without_a_shared_quadratic_part_is_refused_before_allocating():
    rng = np.random.default_rng(0)
    dyn, A0, A1, x0 = leg.random_lq_hypotheses(rng, 2, 2, 20_000)
    with pytest.raises(ValueError, match="replan less often"):
        leg.receding_horizon(dyn, A1, A0, x0, 20_000, lambda s: 1.0, every=1)


# ---- legibility specs (class: refused naming the key / answered) ----------------------------------------
BASE = {"start": [0.0, 0.0], "goal": [1.0, 1.0], "distractors": [[-1.0, 1.0]], "horizon": 1.0, "steps": 20,
        "alpha": 1.0}
QP = {"alpha": None, "goal": [0.0, 1.0], "distractors": [[-1.0, 1.0], [1.0, 1.0]]}
DUBINS = {"dynamics": "dubins", "start": [0.0, 0.0, 1.5]}
ANTICIPATION = {"anticipation": {"alpha_start": 0.5, "alpha_end": 2.0}}
HUGE = 10 ** 400                       # a TOML integer that no float holds: OverflowError before


def spec(**changes):
    d = {**BASE, **changes}
    return {k: v for k, v in d.items() if v is not None}


def with_anticipation(**changes):
    return spec(anticipation={**ANTICIPATION["anticipation"], **changes})


REFUSED = [
    # issue 22's cases
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


# ---- the command line: one line, exit 2, never null ---------------------------------------------------
TOML = 'start = [0, 0]\ngoal = [1, 1]\ndistractors = [[-1, 1]]\nhorizon = 1.0\nsteps = 10\nalpha = 1.0\n'
CLI = [
    (TOML.replace("start = [0, 0]", "start = [1e300, 0]"), "key 'start'"),
    (TOML.replace("alpha = 1.0", "alpha = nan"), "key 'alpha'"),
    (TOML.replace("horizon = 1.0", "horizon = " + "1" * 400), "key 'horizon'"),
    (TOML.replace("steps = 10", "steps = 100000000"), "GiB"),
    (TOML.replace("alpha = 1.0", "eta = -100.0").replace("goal = [1, 1]", "goal = [0, 1]")
     .replace("[[-1, 1]]", "[[-1, 1], [1, 1]]"), "key 'eta'"),
]


@pytest.mark.parametrize("text, phrase", CLI, ids=["start 1e300", "alpha nan", "huge horizon", "steps 1e8", "eta"])
def test_the_command_refuses_in_one_line(text, phrase, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "spec.toml").write_text(text)
    status = main(["motion", "legible", "spec.toml", "--json", "--no-progress", "--out", "o"])
    captured = capsys.readouterr()
    assert status == 2 and len(captured.err.strip().splitlines()) == 1 and phrase in captured.err
    assert captured.out == "" and not (tmp_path / "o").exists()


def test_the_command_never_prints_null_evidence(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "spec.toml").write_text(TOML.replace("[1, 1]", "[1e-300, 1e-300]").replace("[[-1, 1]]",
                                                                                           "[[-1e-300, 1e-300]]"))
    assert main(["motion", "legible", "spec.toml", "--json", "--no-progress", "--out", "o"]) == 0
    results = json.loads(capsys.readouterr().out)
    assert None not in results["evidence"]["legible"] + results["evidence"]["predictable"]
