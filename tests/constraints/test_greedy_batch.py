"""The batched greedy of many runs on one world (mutual.constraints.greedy_batch) against the one-run greedy
inference (Section 2.4) and the compiled feasibility backup: a second implementation of each."""

import numpy as np
import pytest

from mutual.constraints.candidates import constraint_candidates
from mutual.constraints.demonstrations import sample_demonstrations
from mutual.constraints.experiment import chapter3
from mutual.constraints.feasibility import infeasible_candidates
from mutual.constraints.greedy_batch import BatchWorld, RunData, greedy_by_f
from mutual.constraints.gridworld import gridworld
from mutual.constraints.inference import greedy_inference
from mutual.constraints.layouts import layout_family


def _keys(cand, chosen):
    return [("state", int(cand.index[k]), float(cand.psi[k])) if cand.kind[k] == "state" else ("action", int(cand.index[k]))
            for k in chosen]


@pytest.mark.parametrize("scale, width, layout", [(1.0, 7, 0), (4.0, 7, 5), (0.25, 7, 9)])
def test_batched_greedy_makes_the_choices_of_greedy_inference(scale, width, layout):
    setup = chapter3(layout_family()[layout], reward_scale=scale, width=width, horizon=2 * width)
    mdp = setup.grid.mdp
    demos = [sample_demonstrations(mdp, 40, setup.truth, rng=seed) for seed in range(3)]
    world = BatchWorld(mdp)
    batched = greedy_by_f(world, [RunData.of(mdp, d) for d in demos], 5)
    for d, run in zip(demos, batched):
        cand = constraint_candidates(mdp, d)
        one = greedy_inference(mdp, d, cand, 5)
        assert run.chosen == _keys(cand, one.chosen)
        np.testing.assert_allclose(np.exp(run.log_f), one.F, atol=1e-12)
        F1 = np.exp(one.log_f[0])
        for k, key in zip(range(len(cand)), _keys(cand, range(len(cand)))):
            if cand.feasible[k]:
                assert (np.isnan(run.first_round[key]) and not np.isfinite(one.gain[0][k])) or \
                    run.first_round[key] == pytest.approx(np.log(F1[k]), abs=1e-12)
    assert world.backed_up < sum(len(r.chosen) for r in batched) * len(cand)   # shared backups


def test_rejections_equal_the_compiled_feasibility_backup():
    g = gridworld(6, 5, (0, 0), (5, 0), slip=0.1, horizon=10)
    demos = sample_demonstrations(g.mdp, 30, rng=1)
    run = RunData.of(g.mdp, demos)
    rng = np.random.default_rng(0)
    forbidden = rng.random((g.mdp.n_states, g.mdp.n_actions, 150)) < 0.08
    forbidden[:, :, :20] = False
    forbidden[g.state(2, 2), :, 0] = True                   # a state with no move: its neighbourhood dies
    expected = infeasible_candidates(g.mdp, demos, g.mdp.allowed, forbidden)
    got = BatchWorld(g.mdp).rejections(forbidden, [(run, list(range(150)))])[0]
    np.testing.assert_array_equal(got, expected)
    assert expected.any() and not expected.all()


def test_batched_greedy_refuses_worlds_it_cannot_batch():
    g = gridworld(4, 3, (0, 0), (3, 0))
    spread = g.mdp.__class__(g.mdp.transitions, g.mdp.reward, g.mdp.horizon, g.mdp.terminal_reward, None, g.mdp.allowed)
    with pytest.raises(ValueError, match="single start"):
        BatchWorld(spread)
