"""Greedy inference on the points model (``inference``) against independent truth: demonstrations sampled by
enumeration from the exact maximum-entropy distribution of a lattice system (where the grid model is exact), a
hand-written braking controller integrated with RK4, the likelihood interval's coverage computed exactly by
enumeration; bad options, and demonstrations the model cannot follow within the box, refused with the reason."""

import itertools
import math

import numpy as np
import pytest

from mutual.constraints.continuous import Grid, Problem, QuadraticReward, Recording, infer, named_system
from mutual.constraints.continuous import search
from mutual.constraints.continuous.inference import MIN_GAIN
from mutual.constraints.continuous.systems import System

HERE = __file__.rsplit("/", 1)[0]


def line(x, u):
    return np.asarray(u, dtype=float).copy()


def lattice_problem(horizon=6, temperature=0.5):
    """x' = u, u in {-0.5, 0, 0.5}, dt = 0.5: one 0.25-wide cell per step, barycentric (exact on the lattice)."""
    system = System("test_inference:line", ("x",), ("m",), ("u",), ("m/s",), (), {}, HERE)
    grid = Grid.uniform([-1.625], [2.125], [15], [False], ("x",), ("m",))
    return Problem(system, grid, [-0.5, 0.0, 0.5], 0.5, horizon, QuadraticReward([1.5], [1.0], [0.1], [2.0], temperature),
                   scheme="barycentric", substeps=1)


def enumerated(problem, start=0.0):
    """Every control sequence: states (n, T+1), controls (n, T), log-weight R / tau."""
    p, T = problem, problem.horizon
    seqs = np.array(list(itertools.product(range(p.n_actions), repeat=T)))
    u = p.controls[seqs, 0]
    x = start + np.concatenate([np.zeros((len(seqs), 1)), np.cumsum(u * p.dt, axis=1)], axis=1)
    rate = -((x[:, :-1] - 1.5) ** 2 * 1.0 + u ** 2 * 0.1) * p.dt
    R = (rate.sum(axis=1) - 2.0 * (x[:, -1] - 1.5) ** 2) / p.reward.temperature
    return x, u, R


def sample(problem, n, bound, rng):
    x, u, R = enumerated(problem)
    keep = np.ones(len(R), bool) if bound is None else (x <= bound + 1e-12).all(axis=1)
    w = np.where(keep, np.exp(R - R[keep].max()), 0.0)
    picks = rng.choice(len(R), size=n, p=w / w.sum())
    states = tuple(x[k][:, None] for k in picks)
    return Recording(tuple(f"d{i}" for i in range(n)), tuple(np.arange(problem.horizon + 1) * problem.dt for _ in picks),
                     states, tuple(np.r_[u[k], np.nan][:, None] for k in picks))


@pytest.mark.parametrize("draw", range(3))
def test_demonstrations_of_the_exact_model_give_the_true_bound_and_no_constraint_without_one(draw):
    """Sampled from the maximum-entropy distribution itself: under x <= 0.5 (which the task, going to 1.5,
    pushes against) the accepted bound is the largest recorded x, which on this lattice is the truth; with
    no constraint the tightest bound gains too little (the model is right: its gain is Exp(1) in all)."""
    p = lattice_problem()
    rng = np.random.default_rng(draw)
    bounded = infer(p, sample(p, 20, 0.5, rng), rounds=2)
    assert [r.describe(p.grid) for r in bounded.chosen_regions()][:1] == ["x <= 0.5 m"]
    assert bounded.accepted[0]["gain"] >= MIN_GAIN * 20
    free = infer(p, sample(p, 20, None, rng), rounds=2)
    assert free.chosen_regions() == [] and free.stop == "min_gain"
    assert free.best_rejected()["gain_refit"] < free.best_rejected()["needed"]


def test_the_likelihood_interval_covers_the_truth_at_least_95_percent_by_enumeration():
    """One demonstration from the exact model under x <= b_true: the interval {b >= b* : log Z_b - log Z_b* <= log 20}
    contains b_true with probability >= 0.95, summed exactly over every trajectory (b* = its largest x)."""
    p = lattice_problem(horizon=5)
    x, _, R = enumerated(p)
    values = np.arange(0.0, 2.6, 0.25)
    logZ = {v: np.log(np.exp(R[(x <= v + 1e-12).all(axis=1)]).sum()) for v in values}
    for b_true in (0.5, 0.75, 1.0):
        inside = (x <= b_true + 1e-12).all(axis=1)
        prob = np.exp(R[inside] - np.log(np.exp(R[inside]).sum()))
        covered = 0.0
        for path, pr in zip(x[inside], prob):
            top = float(path.max())
            grid = values[values >= top - 1e-12]
            gains = np.array([-logZ[v] for v in grid])
            low, high = search.profile_interval(grid, gains, math.log(20))
            covered += pr * (low - 1e-12 <= b_true <= high + 1e-12)
        assert covered >= 0.95, (b_true, covered)


def braking_demonstrations(n, wall, seed):
    """A hand-written controller (PD towards 2.8 m, noise) with a safety filter that brakes before ``wall``
    (full braking after the step must stop in time), integrated with RK4 -- nothing from the library."""
    rng = np.random.default_rng(seed)
    f = lambda x, u: np.array([x[1], u])   # noqa: E731
    options = np.linspace(-1, 1, 41)

    def step(x, u, dt=0.1, k=10):
        for _ in range(k):
            h = dt / k
            k1 = f(x, u); k2 = f(x + h / 2 * k1, u); k3 = f(x + h / 2 * k2, u); k4 = f(x + h * k3, u)   # noqa: E702
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        return x

    states, controls = [], []
    for _ in range(n):
        x, xs, us = np.array([rng.uniform(-0.2, 0.2), 0.0]), [], []
        xs.append(x)
        for _ in range(40):
            u = float(np.clip(1.5 * (2.8 - x[0]) - 2.0 * x[1] + 0.3 * rng.standard_normal(), -1, 1))
            if wall is not None:
                after = [step(x, c) for c in options]
                ok = np.array([z[0] <= wall and z[0] + max(z[1], 0) ** 2 / 2 <= wall for z in after])
                u = float(options[ok][np.argmin(np.abs(options[ok] - u))]) if ok.any() else -1.0
            x = step(x, u)
            xs.append(x)
            us.append(u)
        states.append(np.array(xs))
        controls.append(np.r_[us, np.nan][:, None])
    return Recording(tuple(f"d{i}" for i in range(n)), tuple(np.arange(41) * 0.1 for _ in states), tuple(states),
                     tuple(controls))


def test_a_hand_written_braking_controller_reveals_its_wall_and_nothing_without_it():
    di = named_system("double_integrator")
    grid = Grid.uniform([-1, -2], [3.5, 2], [31, 31], [False, False], di.state_names, di.state_units)
    problem = Problem(di, grid, [-1, -0.5, 0, 0.5, 1], 0.1, 40, QuadraticReward([2.8, 0], [1, 0.1], [0.1], [10, 1]))
    walled = braking_demonstrations(12, 2.3, 1)
    run = infer(problem, walled, rounds=2)
    first = run.chosen_regions()[0]
    naive = max(s[:, 0].max() for s in walled.states)
    assert first.describe(grid).startswith("position <=") and abs(first.value - 2.3) <= abs(naive - 2.3) + 0.05
    low, high = run.accepted[0]["interval"]
    assert low == pytest.approx(first.value) and low <= 2.3 <= high
    assert infer(problem, braking_demonstrations(12, None, 2), rounds=2).chosen_regions() == []


def test_progress_runs_up_to_one_and_the_model_can_be_reused():
    from mutual.constraints.continuous import point_model
    p = lattice_problem()
    rec = sample(p, 5, 0.5, np.random.default_rng(1))
    seen = []
    first = infer(p, rec, rounds=1, progress=lambda f, d: seen.append(f))
    assert seen[-1] == 1.0 and all(a <= b for a, b in zip(seen, seen[1:]))
    again = infer(p, rec, rounds=1, points=point_model(p))
    assert again.labels() == first.labels()


@pytest.mark.parametrize("options, message", [
    ({"families": ("bound", "cell")}, "'cell' candidates need model='cells'"),
    ({"families": ("blob",)}, "unknown family 'blob'"),
    ({"rounds": 0}, "rounds: must be an integer >= 1"),
    ({"min_gain": -1.0}, "min_gain: must be a finite number"),
    ({"min_gain": float("nan")}, "min_gain"),
    ({"temperature": 0.0}, "temperature: must be 'fit' or a positive number"),
    ({"temperature": "hot"}, "temperature"),
    ({"model": "grid"}, "model: must be 'points' or 'cells'"),
    ({"thresholds": "lemma"}, "apply to model='cells' only"),
])
def test_bad_options_are_refused_with_the_reason(options, message):
    p = lattice_problem()
    rec = sample(p, 3, 0.5, np.random.default_rng(2))
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        infer(p, rec, **options)


def test_a_point_model_of_another_problem_is_refused():
    from mutual.constraints.continuous import point_model
    p = lattice_problem()
    with pytest.raises(ValueError, match="points: built for another problem"):
        infer(p, sample(p, 3, 0.5, np.random.default_rng(3)), points=point_model(lattice_problem()))


@pytest.mark.parametrize("temperature", ["fit", 0.5])
@pytest.mark.parametrize("far", [[1.5, 1.75],                # its start: six steps from 1.5 leave the box (2.125)
                                 [0.5, 1.0, 1.5, 1.75]])     # its end, at t = 3: three steps more leave the box
def test_demonstrations_the_model_cannot_follow_within_the_box_are_refused_naming_them(far, temperature):
    """With only forward controls (one or two cells a step: the lattice, where the grid is exact) the model must
    leave the box within the horizon from where 'far' starts or ends: Z = 0 there, and the likelihood of any
    reward is 0 (not +inf, not a silent fit)."""
    p = lattice_problem()
    p = Problem(p.system, p.grid, [0.5, 1.0], p.dt, p.horizon, p.reward, scheme="barycentric", substeps=1)
    near = np.arange(len(far)) * 0.25
    rec = Recording(("near", "far"), (np.arange(len(far)) * p.dt,) * 2, (near[:, None], np.array(far)[:, None]))
    with pytest.raises(ValueError, match=r"demonstration\(s\) 'far' start \(or end\), every path of the model leaves "
                                         r"the state box within the horizon \(T = 6 steps"):
        infer(p, rec, temperature=temperature)
