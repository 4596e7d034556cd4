"""Constraint inference from continuous demonstrations, against independent truth: on a tiny grid the whole
ranking -- set chance thresholds (eq. 3.3 and Lemma 3.2.1), the forbidden actions, F and the exact
likelihood gain -- equals brute-force enumeration written with plain loops; a hidden velocity limit is
recovered from demonstrations of the true continuous system; recorded controls snap and missing ones are
inferred exactly."""

import math
from dataclasses import replace

import numpy as np
import pytest

from mutual.constraints import constraint_candidates, greedy_inference
from mutual.constraints.continuous import (Bound, Grid, Problem, QuadraticReward, bound_regions, boundary_distance,
                                           discretize, infer, infer_cells, parse_region, region_candidates, rollout,
                                           soft_demonstrator, starts_around, to_demonstrations)

from helpers.continuous import DI, recording_of


TOLERANCE = 1e-9


def tiny(scheme="sample"):
    grid = Grid.uniform([-1, -1], [1, 1], [6, 6], [False, False], DI.state_names, DI.state_units)
    reward = QuadraticReward([0.6, 0.0], [1.0, 0.2], [0.05], [2.0, 1.0], temperature=0.5)
    return Problem(DI, grid, [-1.0, 1.0], 0.25, 3, reward, scheme=scheme, samples=4, seed=3)


def brute_values(S, r, w, T, allowed):
    """V_t(x) of the constrained soft backup (eqs. 2.19-2.21) by loops; -inf for no allowed action."""
    X, A = r.shape
    V = [None] * (T + 1)
    V[T] = list(w)
    Q = [None] * T
    for t in range(T - 1, -1, -1):
        Q[t] = [[-math.inf] * A for _ in range(X)]
        V[t] = [-math.inf] * X
        for x in range(X):
            total = 0.0
            for a in range(A):
                if not allowed[x][a]:
                    continue
                q = r[x, a]
                for y in range(X):
                    if S[x, a, y] > 0:
                        q = -math.inf if V[t + 1][y] == -math.inf else q + S[x, a, y] * V[t + 1][y]
                Q[t][x][a] = q
                total += math.exp(q) if q > -math.inf else 0.0
            V[t][x] = math.log(total) if total > 0 else -math.inf
    return V, Q


def brute_score(S, r, w, T, allowed, demos):
    V, Q = brute_values(S, r, w, T, allowed)
    ll = 0.0
    for xs, acts in zip(demos.states.tolist(), demos.actions.tolist()):
        for t, a in enumerate(acts):
            q = Q[t][xs[t]][a]
            ll = -math.inf if q == -math.inf or ll == -math.inf else ll + q - V[t][xs[t]]
    return V, ll


def brute_candidate(S, inside, demos, rule):
    """psi and the allowed table of the set chance constraint on the cells ``inside`` (entering only)."""
    X, A, _ = S.shape
    SR = [[sum(S[x, a, y] for y in range(X) if inside[y]) for a in range(A)] for x in range(X)]
    psi = 0.0
    for xs, acts in zip(demos.states.tolist(), demos.actions.tolist()):
        for t, a in enumerate(acts):
            if not inside[xs[t]]:
                psi = max(psi, SR[xs[t]][a])
    options = [psi] + sorted({SR[x][a] for x in range(X) for a in range(A) if SR[x][a] > psi + 1e-12})
    return SR, options


def brute_ranking(problem, S_sparse, demos, regions, rule):
    S = S_sparse.toarray().reshape(problem.grid.n_cells, problem.n_actions, -1)
    r, w = problem.rewards()
    X, A = r.shape
    T = problem.horizon
    V0, ll0 = brute_score(S, r, w, T, [[True] * A for _ in range(X)], demos)
    out = {}
    for region in regions:
        inside = region.inside(problem.grid.centers())
        if inside[demos.states.ravel()].any():
            continue                                           # the demonstrations entered it: no candidate
        SR, options = brute_candidate(S, inside, demos, rule)
        for psi in (options if rule == "lemma" else options[:1]):
            allowed = [[inside[x] or SR[x][a] <= psi + 1e-12 for a in range(A)] for x in range(X)]
            V, ll = brute_score(S, r, w, T, allowed, demos)
            if ll > -math.inf or rule == "eq3.3":
                break
        starts = demos.states[:, 0]
        log_f = np.mean([V[0][s] - V0[0][s] for s in starts]) if ll > -math.inf else math.nan
        out[region] = (psi, log_f, (ll - ll0) / demos.n if ll > -math.inf else -math.inf)
    return out


@pytest.mark.parametrize("rule", ["eq3.3", "lemma"])
@pytest.mark.parametrize("scheme", ["sample", "barycentric"])
def test_on_a_tiny_grid_the_ranking_equals_brute_force_enumeration(rule, scheme):
    problem = tiny(scheme)
    rec = recording_of(problem, [(-0.7, 0.0), (-0.6, 0.3), (-0.8, -0.1)], [(1, 1, -1), (1, -1, -1), (1, 1, 1)])
    S = discretize(problem, scheduler="inline")
    mapped = to_demonstrations(problem, rec, S)
    mdp = problem.mdp(mapped.transitions)
    regions = bound_regions(problem.grid)
    cand = region_candidates(mdp, mapped.demos, problem.grid, regions, thresholds=rule)
    assert len(cand) >= 4
    truth = brute_ranking(problem, mapped.transitions, mapped.demos, regions, rule)
    for engine in ("numpy", "gather"):
        result = greedy_inference(mdp, mapped.demos, cand.candidates, 1, engine=engine)
        log_f, gain = result.log_f[0], result.gain[0]
        for k, region in enumerate(cand.regions):
            psi, want_log_f, want_gain = truth[region]
            assert cand.candidates.psi[k] == pytest.approx(psi, abs=1e-12)
            if np.isfinite(want_gain):
                assert log_f[k] == pytest.approx(want_log_f, abs=TOLERANCE)
                assert gain[k] == pytest.approx(want_gain, abs=TOLERANCE)
            else:
                assert not np.isfinite(gain[k])
        order = sorted((k for k in range(len(cand)) if np.isfinite(gain[k])), key=lambda k: truth[cand.regions[k]][1])
        assert result.chosen[0] == order[0]


def test_the_cells_family_is_chapter_3s_own_candidates():
    problem = tiny()
    rec = recording_of(problem, [(-0.7, 0.0), (-0.6, 0.3)], [(1, 1, -1), (1, -1, -1)])
    mapped = to_demonstrations(problem, rec, discretize(problem, scheduler="inline"))
    mdp = problem.mdp(mapped.transitions)
    ours = region_candidates(mdp, mapped.demos, problem.grid, cells=True, thresholds="eq3.3").candidates
    theirs = constraint_candidates(mdp, mapped.demos, actions=False)
    for k, state in enumerate(ours.index):
        j = theirs.find("state", state)
        assert ours.psi[k] == theirs.psi[j]
        assert (ours.forbidden_matrix[:, k] != theirs.forbidden_matrix[:, j]).nnz == 0


def test_the_callback_sees_every_round_and_changes_nothing():
    problem = tiny()
    rec = recording_of(problem, [(-0.7, 0.0), (-0.6, 0.3)], [(1, 1, -1), (1, -1, -1)])
    mapped = to_demonstrations(problem, rec, discretize(problem, scheduler="inline"))
    mdp = problem.mdp(mapped.transitions)
    cand = region_candidates(mdp, mapped.demos, problem.grid, bound_regions(problem.grid)).candidates
    seen = []
    a = greedy_inference(mdp, mapped.demos, cand, 3, min_gain=0.01, on_round=lambda *args: seen.append(args))
    b = greedy_inference(mdp, mapped.demos, cand, 3, min_gain=0.01)
    assert a.chosen == b.chosen and a.stop == b.stop
    assert [s[3] for s in seen] == a.chosen + ([None] if a.stop == "min_gain" else [])


@pytest.mark.parametrize("model", ["points", "cells"])
def test_a_hidden_velocity_limit_is_recovered_from_demonstrations_of_the_continuous_system(model):
    """A Boltzmann demonstrator on a 45 x 45 grid, rolled out on the true dynamics, never exceeds
    0.5 m/s; inference on 15 x 15 cells puts the velocity's upper bound first: the points model at the
    fastest recorded speed, the cells model at the cell edge above it (within one cell width, 0.2 m/s)."""
    grid = Grid.uniform([-1.5, -1.5], [1.5, 1.5], [15, 15], [False, False], DI.state_names, DI.state_units)
    reward = QuadraticReward([1.0, 0.0], [1.0, 0.1], [0.05], [5.0, 1.0], temperature=0.5)
    problem = Problem(DI, grid, [-1.0, 0.0, 1.0], 0.2, 20, reward)
    hidden = [parse_region("velocity <= 0.5", DI.state_names)]
    demonstrator = soft_demonstrator(problem, hidden, [45, 45], scheduler="inline")
    rec = rollout(demonstrator, starts_around([-1.0, 0.0], [0.1, 0.0], 20, seed=0), seed=1)
    assert max(s[:, 1].max() for s in rec.states) <= 0.5
    fastest = max(s[:, 1].max() for s in rec.states)
    if model == "cells":
        run = infer_cells(problem, rec, rounds=3, min_gain=0.1, scheduler="inline")
        assert run.ranking().iloc[0]["constraint"] == "velocity <= 0.5 m/s"
    else:
        run = infer(problem, rec, rounds=3)
        assert run.chosen_regions()[0].value == pytest.approx(fastest)
    first = run.chosen_regions()[0]
    assert isinstance(first, Bound) and first.dim == 1 and first.side == "upper"
    assert boundary_distance(first, hidden[0]) <= 0.2 + 1e-9


def test_recorded_controls_snap_and_missing_ones_are_inferred_exactly():
    problem = tiny()
    rec = recording_of(problem, [(-0.7, 0.0), (-0.6, 0.3)], [(1, 1, -1), (1, -1, -1)])
    S = discretize(problem, scheduler="inline")
    recorded = to_demonstrations(problem, rec, S)
    noisy = replace(rec, controls=tuple(c + 0.2 * np.r_[1, -1, 1, 0][:, None] for c in rec.controls))
    missing = replace(rec, controls=None)
    for other, snapped, inferred in ((noisy, 6, 0), (missing, 0, 6)):
        mapped = to_demonstrations(problem, other, S)
        assert np.array_equal(mapped.demos.actions, recorded.demos.actions)
        assert (mapped.snapped, mapped.inferred) == (snapped, inferred)
    assert to_demonstrations(problem, missing, S).miss == pytest.approx(0.0, abs=1e-9)
    assert "INFERRED" in to_demonstrations(problem, missing, S).notes()


def test_steps_the_model_gives_probability_zero_are_added_with_a_small_weight():
    problem = tiny("barycentric")
    rec = recording_of(problem, [(-0.7, 0.0), (-0.6, 0.3)], [(1, 1, -1), (1, -1, -1)])
    S = discretize(problem, scheduler="inline")
    jumped = replace(rec, states=tuple(np.where(np.arange(len(s))[:, None] == 2, s + [0.5, 0.0], s) for s in rec.states))
    mapped = to_demonstrations(problem, jumped, S)
    assert mapped.added >= 1
    np.testing.assert_allclose(np.asarray(mapped.transitions.sum(axis=1)).ravel(), 1.0, atol=1e-12)
    rows = mapped.demos.states[:, :-1] * problem.n_actions + mapped.demos.actions
    assert np.all(np.asarray(mapped.transitions[rows.ravel(), mapped.demos.states[:, 1:].ravel()]) > 0)


def test_measured_runs_fresh_or_in_this_process_with_the_same_result():
    """Notebook 09's timer: a fresh process reports its peak memory; a quick run's (in this process) none."""
    import math
    from mutual.constraints.continuous import experiments
    result, seconds, peak = experiments.measured(math.hypot, 3.0, 4.0)
    assert result == 5.0 and seconds >= 0 and peak > 0
    result, seconds, peak = experiments.measured(math.hypot, 3.0, 4.0, fresh=False)
    assert result == 5.0 and seconds >= 0 and math.isnan(peak)
    assert math.isnan(experiments.idle_memory(fresh=False))
