"""The exact likelihood of continuous demonstrations (mutual.constraints.continuous.pointwise, .occupancy, .evidence)
against brute-force enumeration of every control sequence of a deterministic system.

On a lattice-aligned system (a 1-D integrator whose every control moves a whole number of cells, the
barycentric scheme: successors land on cell centres, interpolation is exact) the grid model is exact, so
Z, the likelihood of a demonstration and the gain of a bound must equal enumeration to rounding. On a
system that is not aligned (the double integrator, Monte Carlo cells) they converge to it as the cells shrink.
"""

import itertools
import math

import numpy as np
import pytest

from mutual.constraints.continuous import Bound, Box, Disk, Grid, Problem, QuadraticReward, Recording, named_system
from mutual.constraints.continuous import evidence as ev
from mutual.constraints.continuous import occupancy
from mutual.constraints.continuous import pointwise as pw
from mutual.constraints.continuous.systems import System

HERE = __file__.rsplit("/", 1)[0]


def integrator_1d(cells=13, horizon=4, temperature=0.7):
    """x' = u on the box [-1.625, 1.625] (13 cells of 0.25, centres -1.5 .. 1.5); u in {-0.5, 0, 0.5} for dt = 0.5:
    one cell per step."""
    system = System("test_pointwise:line", ("x",), ("m",), ("u",), ("m/s",), (), {}, HERE)
    grid = Grid.uniform([-1.625], [1.625], [cells], [False], ("x",), ("m",))
    reward = QuadraticReward([0.75], [1.0], [0.2], [2.0], temperature)
    return Problem(system, grid, [-0.5, 0.0, 0.5], 0.5, horizon, reward, scheme="barycentric", substeps=1)


def off_the_lattice():
    """:func:`integrator_1d` with controls that land between cell centres."""
    p = integrator_1d()
    return Problem(p.system, p.grid, [-0.37, 0.0, 0.41], 0.5, p.horizon, p.reward, scheme="barycentric", substeps=1)


def random_log_Z(p, rng):
    """Allowed cells (about 70 %) and a log Z on them, -inf on the others."""
    cell_ok = rng.random(p.grid.n_cells) > 0.3
    return cell_ok, np.where(cell_ok, rng.normal(scale=5.0, size=p.grid.n_cells), -np.inf)


def line(x, u):
    return np.asarray(u, dtype=float).copy()


def enumerate_paths(problem, start, horizon):
    """Every control sequence from ``start``, all at once: (states (n, T+1, d), controls (n, T, m), return R / tau)."""
    p = problem
    seqs = np.array(list(itertools.product(range(p.n_actions), repeat=horizon)))
    x = np.tile(np.asarray(start, dtype=float), (len(seqs), 1))
    states, R = [x], np.zeros(len(seqs))
    for t in range(horizon):
        u = p.controls[seqs[:, t]]
        R += p.reward.rate(p.grid, x, u) * p.dt
        x = p.step(x, u)
        states.append(x)
    return np.stack(states, axis=1), p.controls[seqs], (R + p.reward.terminal(p.grid, x)) / p.reward.temperature


def log_Z(returns, keep):
    return float(np.log(np.exp(returns[keep]).sum())) if keep.any() else -math.inf


def recording(states, controls, dt):
    n = len(states)
    return Recording(tuple(f"d{i}" for i in range(n)), tuple(np.arange(s.shape[0]) * dt for s in states),
                     tuple(states), tuple(np.vstack([c, np.full((1, c.shape[1]), np.nan)]) for c in controls))


def central_differences(value, w, h=1e-6):
    """The gradient of ``value`` at the weights ``w`` by central differences."""
    return np.array([(value(w + h * e) - value(w - h * e)) / (2 * h) for e in np.eye(w.size)])


def likelihood_gradient_by_differences(model, data, regions, w):
    return central_differences(lambda v: ev.log_likelihood(model, data, regions, v)[0], w)


def assert_F_is_the_ratio_of_partition_functions(model, logZ, base, candidates, w, F):
    """F_t (cells, candidates) at every time t of ``F`` against Z_{C+,t} / Z_{C,t} from separate log Z (0 where Z_C = 0)."""
    for k, c in enumerate(candidates):
        logZ_plus = pw.log_partition(model, base + [c], w)
        for t, F_t in F.items():
            reached = np.isfinite(logZ[t])
            exact = np.where(reached, np.exp(logZ_plus[t] - np.where(reached, logZ[t], 0.0)), 0.0)
            np.testing.assert_allclose(F_t[:, k], exact, rtol=1e-12, atol=1e-13)


def test_a_successors_log_Z_is_the_mean_of_Z_over_its_allowed_vertices_with_their_weights_renormalized():
    """Off the lattice (controls that land between centres), log Z at each move's successor against the formula
    in plain NumPy: log(sum_v lambda_v Z(v) / sum_v lambda_v) over the allowed vertices, -inf where none is."""
    p = off_the_lattice()
    moves = pw.point_model(p).moves
    rng = np.random.default_rng(5)
    cell_ok, logZ_next = random_log_Z(p, rng)
    weight = np.exp(moves.log_weight) * cell_ok[moves.target]
    with np.errstate(divide="ignore", invalid="ignore"):
        expected = np.log((weight * np.exp(logZ_next[moves.target])).sum(axis=1) / weight.sum(axis=1))
    expected[weight.sum(axis=1) == 0] = -np.inf
    got = pw.successor_log_values(moves, logZ_next, cell_ok)
    assert 0 < np.isneginf(got).sum() < len(got) and np.array_equal(np.isneginf(got), np.isneginf(expected))
    np.testing.assert_allclose(got[np.isfinite(got)], expected[np.isfinite(expected)], rtol=1e-12)


def test_spreading_mass_keeps_it_whole_splits_it_as_lambda_Z_over_the_allowed_vertices_and_reads_only_moving_mass():
    """The occupancy after one step, against the formula in plain NumPy over every move: a successor's mass split
    over its vertices as lambda Z(vertex) / sum over its allowed vertices of lambda Z, so no mass is lost where a
    vertex is forbidden (the total is the mass of the moves with an allowed vertex); the moves without mass are
    skipped, which must not change a bit."""
    p = off_the_lattice()
    moves = pw.point_model(p).moves
    rng = np.random.default_rng(7)
    cell_ok, logZ_next = random_log_Z(p, rng)
    norm = pw.successor_norm(moves, cell_ok)
    at = pw.successor_log_values(moves, logZ_next, cell_ok, norm)
    mass = np.where(rng.random(moves.n_moves) < 0.3, rng.random(moves.n_moves), 0.0)
    weight = np.exp(moves.log_weight + logZ_next[moves.target])
    with np.errstate(invalid="ignore"):
        share = np.nan_to_num(weight / weight.sum(axis=1, keepdims=True))
    every_move = np.bincount(moves.target.ravel(), weights=(mass[:, None] * share).ravel(), minlength=p.grid.n_cells)
    got = occupancy._spread(moves, mass, logZ_next, at, norm, p.grid.n_cells)
    straddling = np.isfinite(at) & (norm > 0) & (mass > 0)
    assert straddling.any() and 0 < np.count_nonzero(mass) < moves.n_moves
    np.testing.assert_allclose(got, every_move, rtol=1e-12, atol=1e-15)
    assert got.sum() == pytest.approx(mass[np.isfinite(at)].sum(), rel=1e-12)
    shares = pw.vertex_shares(moves.log_weight, moves.target, logZ_next, at, norm)
    same_shares = np.bincount(moves.target.ravel(), weights=(mass[:, None] * shares).ravel(), minlength=p.grid.n_cells)
    assert np.array_equal(got, same_shares)


def test_the_satisfaction_ratio_equals_the_ratio_of_partition_functions_where_successors_straddle_a_bound():
    """Theorem 2.3.1's F = Z_{C+} / Z_C by the ratio backup (:func:`.pointwise.satisfaction`, on the cells;
    :func:`.pointwise.point_ratios`, at continuous points) against log Z computed under C and under C+
    separately. Under the bound at 0.72 a move from the centre 0.5 lands at 0.705, between an allowed and a
    forbidden vertex: the case that needs the shares renormalized."""
    p = off_the_lattice()
    model, w = pw.point_model(p), pw.file_weights(p) * np.array([1.0, 0.7, 1.3])
    points = pw.point_moves(p, np.array([[0.1], [0.33], [-0.52]]))
    candidates = [Bound(0, "upper", 0.3), Bound(0, "lower", -0.6)]

    def log_Z_at_points(regions):
        logZ = pw.log_partition(model, regions, w)
        return pw.point_log_values(points, logZ[1], pw.allowed_moves(regions, points),
                                   pw.points_allowed(model, regions).any(axis=1), w)

    for base in ([], [Bound(0, "upper", 0.72)]):
        logZ = pw.log_partition(model, base, w)
        F = pw.satisfaction(model, logZ, base, candidates, w, {0: None, 1: None, 2: None})
        assert_F_is_the_ratio_of_partition_functions(model, logZ, base, candidates, w, F)
        at_points = pw.point_ratios(model, points, logZ[1], F[1], base, candidates, w)
        exact = np.stack([np.exp(log_Z_at_points(base + [c]) - log_Z_at_points(base)) for c in candidates], axis=1)
        np.testing.assert_allclose(at_points, exact, rtol=1e-12)


def in_box(problem, states):
    """(n,) whether each enumerated path stays in the grid's box."""
    return ~problem.grid.outside(states.reshape(-1, states.shape[2])).any(axis=1).reshape(states.shape[:2]).any(axis=1)


@pytest.mark.parametrize("bound, start", [(None, 0.0), (0.3, 0.0), (0.75, 0.0), (1.1, 0.0),
                                          (None, 1.0), (2.0, 1.0)])  # from 1.0 four steps of 0.25 can leave the box
def test_on_a_lattice_system_log_Z_at_the_start_equals_enumeration_of_the_paths_that_stay_in_the_box(bound, start):
    p = integrator_1d()
    start = [start]
    states, _, returns = enumerate_paths(p, start, p.horizon)
    regions = [] if bound is None else [Bound(0, "upper", bound)]
    satisfy = np.ones(len(returns), dtype=bool) if bound is None else (states[:, :, 0] <= bound).all(axis=1)
    keep = in_box(p, states) & satisfy
    if start[0] == 1.0:
        assert keep.sum() < satisfy.sum()  # the box acts: some paths that satisfy the bound leave it
    model = pw.point_model(p)
    logZ = pw.log_partition(model, regions, p.reward.temperature)
    moves = pw.point_moves(p, np.array([start]))
    cell_ok = pw.points_allowed(model, regions).any(axis=1)
    value = pw.point_log_values(moves, logZ[1], pw.allowed_moves(regions, moves), cell_ok, p.reward.temperature)
    assert value[0] == pytest.approx(log_Z(returns, keep), abs=1e-9)


def test_on_a_lattice_system_the_likelihood_and_the_gain_of_a_bound_equal_enumeration():
    p = integrator_1d()
    states, controls, returns = enumerate_paths(p, [0.0], p.horizon)
    rng = np.random.default_rng(4)
    b = 0.6
    inside = (states[:, :, 0] <= b).all(axis=1)
    prob = np.where(inside, np.exp(returns - returns.max()), 0.0)
    picks = rng.choice(len(returns), size=5, p=prob / prob.sum())
    data = ev.demonstrated(p, recording(states[picks], controls[picks], p.dt))
    model = pw.point_model(p)
    truth_ll = {}
    for name, keep, regions in (("free", np.ones(len(returns), bool), []), ("bound", inside, [Bound(0, "upper", b)])):
        ll, _ = ev.log_likelihood(model, data, regions, p.reward.temperature)
        truth_ll[name] = float(np.sum(returns[picks]) - len(picks) * log_Z(returns, keep))
        assert ll == pytest.approx(truth_ll[name], abs=1e-8)
    _, logZ = ev.log_likelihood(model, data, [], p.reward.temperature)
    gain = ev.candidate_gains(model, data, logZ, [], [Bound(0, "upper", b)], p.reward.temperature)[0]
    assert gain == pytest.approx(truth_ll["bound"] - truth_ll["free"], abs=1e-8)



def test_the_box_is_known_a_bound_at_its_edge_gains_nothing_and_one_inside_it_what_enumeration_says():
    """Demonstrations near the box's upper edge (1.625), drawn from the paths that stay below 1.4: the bound at
    the edge forbids no move the box allows (gain 0: clipping the moves that leave onto the box made it gain
    what the box explains), and the one at 1.4 gains the exact difference of log-likelihoods by enumeration."""
    p = integrator_1d()
    states, controls, returns = enumerate_paths(p, [1.0], p.horizon)
    box = in_box(p, states)
    inside = box & (states[:, :, 0] <= 1.4).all(axis=1)
    assert inside.sum() < box.sum() < len(box)
    prob = np.where(inside, np.exp(returns - returns.max()), 0.0)
    picks = np.random.default_rng(8).choice(len(returns), size=6, p=prob / prob.sum())
    data = ev.demonstrated(p, recording(states[picks], controls[picks], p.dt))
    model = pw.point_model(p)
    ll, logZ = ev.log_likelihood(model, data, [], p.reward.temperature)
    assert ll == pytest.approx(float(np.sum(returns[picks]) - len(picks) * log_Z(returns, box)), abs=1e-8)
    exact = len(picks) * (log_Z(returns, box) - log_Z(returns, inside))
    gains = ev.candidate_gains(model, data, logZ, [], [Bound(0, "upper", 1.625), Bound(0, "upper", 1.4)],
                               p.reward.temperature)
    assert gains[0] == pytest.approx(0.0, abs=1e-12)
    assert gains[1] == pytest.approx(exact, abs=1e-8) and gains[1] > 0.1

def lattice_plane(periodic):
    """x' = u in the plane on [-1.625, 1.625]^2 (13 x 13 cells of 0.25), u in {-0.5, 0, 0.5}^2, dt = 0.5, barycentric
    (lattice-aligned: exact), y periodic or not."""
    system = System("test_pointwise:line", ("x", "y"), ("m", "m"), ("ux", "uy"), ("m/s", "m/s"),
                    ("y",) if periodic else (), {}, HERE)
    grid = Grid.uniform([-1.625, -1.625], [1.625, 1.625], [13, 13], [False, periodic], ("x", "y"), ("m", "m"))
    reward = QuadraticReward([0.0, 0.0], [0.75, 0.5], [0.2, 0.3], [2.0, 1.0], 0.7)
    controls = np.array(list(itertools.product([-0.5, 0.0, 0.5], repeat=2)))
    return Problem(system, grid, controls, 0.5, 3, reward, scheme="barycentric", substeps=1)


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("start", [(1.5, -1.5), (-1.5, -1.25), (0.0, 1.5), (0.25, 0.0)])   # corners, edges, inside
def test_in_two_dimensions_log_Z_near_the_box_corners_and_lower_edges_equals_enumeration_within_the_box(start,
                                                                                                     periodic):
    """Held out (the reviewer's cases): a periodic coordinate is never an edge; lower edges and corners are; the
    paths that satisfy a bound but leave the box do not count."""
    p = lattice_plane(periodic)
    states, _, returns = enumerate_paths(p, start, p.horizon)
    model = pw.point_model(p)
    box = in_box(p, states)
    stays_in = start == (0.25, 0.0) or (periodic and start == (0.0, 1.5))    # y wraps: 1.5 is no edge then
    assert box.all() == stays_in
    for regions in ([], [Bound(0, "upper", 1.1)], [Bound(1, "lower", -1.2)]):
        keep = box.copy()
        for r in regions:
            keep &= ~r.inside(states.reshape(-1, 2)).reshape(states.shape[:2]).any(axis=1)
        logZ = pw.log_partition(model, regions, p.reward.temperature)
        moves = pw.point_moves(p, np.array([start]))
        cell_ok = pw.points_allowed(model, regions).any(axis=1)
        value = pw.point_log_values(moves, logZ[1], pw.allowed_moves(regions, moves), cell_ok, p.reward.temperature)
        assert value[0] == pytest.approx(log_Z(returns, keep), abs=1e-9), regions


@pytest.mark.parametrize("keep_bytes", [pw.KEEP_BYTES, 0])
@pytest.mark.parametrize("steps", [4, 2])  # whole demonstrations, and prefixes (their ends enter the gradient)
def test_the_likelihood_gradient_in_the_weights_equals_finite_differences_kept_successors_or_not(keep_bytes, steps,
                                                                                                 monkeypatch):
    """Eq. 2.8's gradient (expected less demonstrated features) against central differences of the exact
    log-likelihood, under a bound, with log Z at the successors kept from the value (barycentric) or
    recomputed (KEEP_BYTES = 0): the same to rounding."""
    monkeypatch.setattr(pw, "KEEP_BYTES", keep_bytes)
    p = integrator_1d()
    states, controls, returns = enumerate_paths(p, [0.0], p.horizon)
    prob = np.where((states[:, :, 0] <= 0.6).all(axis=1), np.exp(returns - returns.max()), 0.0)
    picks = np.random.default_rng(2).choice(len(returns), size=4, p=prob / prob.sum())
    data = ev.demonstrated(p, recording(states[picks][:, :steps + 1], controls[picks][:, :steps], p.dt))
    assert (data.ends is None) == (steps == p.horizon)
    model, regions = pw.point_model(p), [Bound(0, "upper", 0.6)]
    w = pw.file_weights(p) * np.array([1.0, 0.7, 1.3])
    successors = ["from an earlier call"]                  # replaced when kept, emptied when not
    ll, logZ = ev.log_likelihood(model, data, regions, w, successors)
    assert len(successors) == (p.horizon if keep_bytes else 0)
    grad = ev.log_likelihood_gradient(model, data, regions, w, logZ, successors)
    np.testing.assert_allclose(grad, likelihood_gradient_by_differences(model, data, regions, w), rtol=1e-6, atol=1e-8)

@pytest.mark.parametrize("bound", [0.7, 0.72])
def test_the_gradient_from_the_ends_of_prefixes_equals_finite_differences_off_the_lattice_under_a_bound(bound):
    """Prefixes of 2 steps (their ends enter the gradient), controls that land between centres: the expected
    features from the ends (:func:`.occupancy.expected_features`) against central differences of their log Z
    (:func:`.pointwise.point_log_values`). Under the bound at 0.7 the first step from an end straddles it (an
    allowed successor with a forbidden vertex); under 0.72 a step between cells does (0.5 -> 0.705)."""
    p = off_the_lattice()
    states, controls, returns = enumerate_paths(p, [0.0], p.horizon)
    prob = np.where((states[:, :, 0] <= bound).all(axis=1), np.exp(returns - returns.max()), 0.0)
    picks = np.random.default_rng(2).choice(len(returns), size=4, p=prob / prob.sum())
    data = ev.demonstrated(p, recording(states[picks][:, :3], controls[picks][:, :2], p.dt))
    model, regions = pw.point_model(p), [Bound(0, "upper", bound)]
    w = pw.file_weights(p) * np.array([1.0, 0.7, 1.3])
    cell_ok = pw.points_allowed(model, regions).any(axis=1)

    def log_z_at_the_ends(weights):
        logZ = pw.log_partition(model, regions, weights)
        return pw.point_log_values(data.ends, logZ[data.steps + 1], pw.allowed_moves(regions, data.ends), cell_ok,
                                   weights).sum()

    expected = occupancy.expected_features(model, data.ends, data.steps, pw.log_partition(model, regions, w), regions, w)
    np.testing.assert_allclose(-expected, central_differences(log_z_at_the_ends, w), rtol=1e-6, atol=1e-8)


def test_among_consistent_bounds_the_tightest_is_the_most_likely_by_enumeration():
    """Lemma 3.2.1's argument for a family of bounds: the enumerated gain falls as the bound loosens."""
    p = integrator_1d(horizon=5)
    states, _, returns = enumerate_paths(p, [0.0], p.horizon)
    free = log_Z(returns, np.ones(len(returns), bool))
    values = [0.5, 0.55, 0.75, 1.0, 1.25]
    gains = [free - log_Z(returns, (states[:, :, 0] <= v).all(axis=1)) for v in values]
    assert all(a >= b for a, b in zip(gains, gains[1:])) and gains[0] > gains[-1]
    model = pw.point_model(p)
    data = ev.demonstrated(p, recording(states[:1] * 0 + states[:1].clip(max=0.5), np.zeros((1, 5, 1)), p.dt))
    _, logZ = ev.log_likelihood(model, data, [], p.reward.temperature)
    ours = ev.candidate_gains(model, data, logZ, [], [Bound(0, "upper", v) for v in values], p.reward.temperature)
    assert np.allclose(ours, gains, atol=1e-8)


def test_off_the_lattice_the_monte_carlo_cells_converge_to_enumeration():
    """The double integrator (not lattice-aligned), 3 controls, T = 5: |log Z_grid - log Z_exact| at 11, 41
    and 161 cells per coordinate, with and without a velocity bound: large on the coarsest grid, below
    0.05 on the finer two (Monte Carlo cells: the error is not monotone in between)."""
    di = named_system("double_integrator")
    reward = QuadraticReward([1.0, 0.0], [1.0, 0.2], [0.1], [1.0, 0.5], 0.5)
    start = [0.1, 0.2]

    def problem(cells):
        grid = Grid.uniform([-1.5, -2.0], [2.5, 2.0], [cells, cells], [False, False], di.state_names, di.state_units)
        return Problem(di, grid, [-1.0, 0.0, 1.0], 0.25, 5, reward, samples=16)

    states, _, returns = enumerate_paths(problem(11), start, 5)
    errors = {}
    for regions, keep in (([], np.ones(len(returns), bool)), ([Bound(1, "upper", 0.6)], (states[:, :, 1] <= 0.6).all(1))):
        exact = log_Z(returns, keep)
        for cells in (11, 41, 161):
            p = problem(cells)
            model = pw.point_model(p)
            logZ = pw.log_partition(model, regions, reward.temperature)
            moves = pw.point_moves(p, np.array([start]))
            value = pw.point_log_values(moves, logZ[1], pw.allowed_moves(regions, moves),
                                        pw.points_allowed(model, regions).any(axis=1), reward.temperature)[0]
            errors[(len(regions), cells)] = abs(value - exact)
    for k in (0, 1):
        assert errors[(k, 41)] < 0.05 and errors[(k, 161)] < 0.05 and errors[(k, 11)] > 2 * errors[(k, 161)]


@pytest.fixture(scope="module")
def plane():
    """A double integrator on a 9 x 9 barycentric grid, 5 controls that land between centres, under a lower
    velocity bound, a box and a disk (27 allowed moves reach a successor with a forbidden vertex, 3 of them two),
    and 6 demonstrations of 5 steps drawn among the enumerated paths from two starts that satisfy them."""
    di = named_system("double_integrator")
    reward = QuadraticReward([1.0, 0.0], [1.0, 0.2], [0.1], [1.0, 0.5], 0.5)
    grid = Grid.uniform([-1.5, -2.0], [2.5, 2.0], [9, 9], [False, False], di.state_names, di.state_units)
    p = Problem(di, grid, [-1.0, -0.3, 0.0, 0.45, 1.0], 0.25, 5, reward, scheme="barycentric")
    base = [Bound(1, "lower", -0.63), Box((0, 1), (0.9, 0.2), (1.6, 0.9)), Disk((0, 1), (-0.6, -0.9), 0.45)]
    rng, states, controls = np.random.default_rng(3), [], []
    for start in ([0.1, 0.2], [0.4, -0.3]):
        S, U, _ = enumerate_paths(p, start, p.horizon)
        keep = ~np.any([r.inside(S.reshape(-1, 2)).reshape(S.shape[:2]).any(axis=1) for r in base], axis=0)
        picks = rng.choice(np.flatnonzero(keep), size=3, replace=False)
        states.append(S[picks])
        controls.append(U[picks])
    return p, base, np.concatenate(states), np.concatenate(controls), pw.file_weights(p) * np.array([1.0, 1.3, 0.7, 1.1, 0.9])


@pytest.mark.parametrize("steps", [5, 2])
def test_in_two_dimensions_the_gradient_equals_finite_differences_where_successors_straddle_regions(plane, steps):
    """A held-out case of the straddling class (2-D, a lower bound, a box, a disk; whole demonstrations and
    prefixes): eq. 2.8's gradient against central differences of the exact log-likelihood."""
    p, base, states, controls, w = plane
    model = pw.point_model(p)
    data = ev.demonstrated(p, recording(states[:, :steps + 1], controls[:, :steps], p.dt))
    ll, logZ = ev.log_likelihood(model, data, base, w)
    grad = ev.log_likelihood_gradient(model, data, base, w, logZ)
    numeric = likelihood_gradient_by_differences(model, data, base, w)
    assert np.isfinite(ll) and np.abs(numeric).max() > 0.1
    np.testing.assert_allclose(grad, numeric, rtol=1e-6, atol=1e-7)


def test_in_two_dimensions_a_candidates_gain_equals_the_difference_of_exact_log_likelihoods(plane):
    """The gains of bounds, a disk and a box added to a non-empty constraint set (F by the ratio backup,
    :func:`.evidence.candidate_gains`) against the exact log-likelihoods with and without each, from prefixes
    of 2 steps (their ends enter the gain), and F on the cells against Z_{C+} / Z_C at every time step."""
    p, base, states, controls, w = plane
    model = pw.point_model(p)
    candidates = [Bound(0, "upper", 0.83), Bound(1, "lower", -0.2), Bound(0, "lower", -0.35),
                  Disk((0, 1), (0.9, -0.6), 0.4), Box((0, 1), (-1.2, 0.3), (-0.5, 1.1))]
    data = ev.demonstrated(p, recording(states[:, :3], controls[:, :2], p.dt))
    ll, logZ = ev.log_likelihood(model, data, base, w)
    gains = ev.candidate_gains(model, data, logZ, base, candidates, w)
    exact = np.array([ev.log_likelihood(model, data, base + [c], w)[0] - ll for c in candidates])
    assert np.isfinite(exact).sum() >= 3 and np.abs(exact[np.isfinite(exact)]).max() > 0.01
    np.testing.assert_allclose(gains[np.isfinite(exact)], exact[np.isfinite(exact)], rtol=1e-9, atol=1e-9)
    F = pw.satisfaction(model, logZ, base, candidates, w, set(range(p.horizon + 1)))
    assert_F_is_the_ratio_of_partition_functions(model, logZ, base, candidates, w, F)


def test_the_allowed_moves_kept_for_a_constraint_set_are_those_computed_afresh_and_cannot_be_changed(plane):
    """:func:`.pointwise.allowed_moves` keeps Phi_C for the last few sets: a set asked again (equal, not the same
    object), after others pushed it out, or with an unhashable field gives what the regions say move by move."""
    p, base, *_ = plane
    moves = pw.point_model(p).moves

    def afresh(regions):
        return moves.in_box & ~np.any([pw.blocked(r, moves.point, moves.successor) for r in regions], axis=0)
    sets = [base[:k] for k in range(len(base) + 1)] + [[Disk((0, 1), (0.9, -0.6), 0.4 + 0.05 * i)] for i in range(6)]
    for regions in sets + sets[::-1] + [[Disk((0, 1), [-0.6, -0.9], 0.45)]]:
        ok = pw.allowed_moves(regions, moves)
        np.testing.assert_array_equal(ok, afresh(regions) if regions else moves.in_box)
        assert not ok.flags.writeable
    np.testing.assert_array_equal(pw.allowed_moves((r for r in base[1:]), moves), afresh(base[1:]))  # a generator
    assert len(moves.allowed_kept) == pw.KEPT_SETS
    assert pw.allowed_moves([Bound(1, "lower", -0.63)], moves) is pw.allowed_moves((Bound(1, "lower", -0.63),), moves)
