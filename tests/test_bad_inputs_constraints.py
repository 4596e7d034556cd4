"""Bad inputs to the constraints subpackage (chapters 2-3), table-driven: every case must raise
the stated exception type with a message naming the argument (or, for loaders, the file, the
line and the column). ValueError for bad values, TypeError for objects of the wrong type."""

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.sparse as sp

from mutual.constraints.backup import log_partition, rank_candidates
from mutual.constraints.candidates import constraint_candidates
from mutual.constraints.chance import chance_forbidden, constraint_mask
from mutual.constraints.complexity import power_law_exponent
from mutual.constraints.demonstrations import (Demonstrations, check_demonstrations, load_demonstrations,
                                               sample_demonstrations, write_demonstrations)
from mutual.constraints.experiment import chapter3
from mutual.constraints.explore import inference_round_view, inference_run
from mutual.constraints.gridworld import GRID_ACTIONS, gridworld
from mutual.constraints.inference import greedy_inference, horizon_sensitivity
from mutual.constraints.mdp import MDP, soft_bellman_backup

G = gridworld(4, 4, (0, 0), (3, 0))
MDP0 = G.mdp
DEMOS = sample_demonstrations(MDP0, 5, rng=0)
CAND = constraint_candidates(MDP0, DEMOS)
X, A = MDP0.n_states, MDP0.n_actions
LOITER = GRID_ACTIONS.index("loiter")
SIMPLE = dict(transitions=np.ones((2, 1, 2)) / 2, reward=np.zeros((2, 1)), horizon=3)


def _mdp(**kwargs):
    return MDP(**{**SIMPLE, **kwargs})


def _grid(**kwargs):
    return gridworld(**{**dict(width=4, height=4, start=(0, 0), goal=(3, 0)), **kwargs})


def _greedy(**kwargs):
    args = dict(mdp=MDP0, demos=DEMOS, candidates=CAND, rounds=2)
    return greedy_inference(**{**args, **kwargs})


def _written():
    path = Path(tempfile.mkdtemp(prefix="mutual-bad-")) / "demos.csv"
    write_demonstrations(path, sample_demonstrations(MDP0, 3, rng=2))
    return path


def _load_edited(edit):
    """Write a valid demonstrations CSV, apply ``edit`` to its text lines, load it."""
    path = _written()
    lines = path.read_text().splitlines()
    path.write_text("\n".join(edit(lines)) + "\n")
    return load_demonstrations(path, MDP0)


def _replace(line_no, column, value):
    """An edit that sets ``column`` of file line ``line_no`` (1 = header) to ``value``."""
    def edit(lines):
        header = lines[0].split(",")
        cells = lines[line_no - 1].split(",")
        cells[header.index(column)] = value
        lines[line_no - 1] = ",".join(cells)
        return lines
    return edit


def _empty_file():
    path = Path(tempfile.mkdtemp(prefix="mutual-bad-")) / "empty.csv"
    path.write_text("")
    return load_demonstrations(path, MDP0)


def _off_goal_loiter():
    return check_demonstrations(MDP0, Demonstrations(np.array([[0, 0]]), np.array([[LOITER]])))


CASES = [
    # gridworld (Section 3.3)
    (_grid, (), dict(width=1), ValueError, "width"),
    (_grid, (), dict(width=4.0), ValueError, "width"),
    (_grid, (), dict(start=(4, 0)), ValueError, "start"),
    (_grid, (), dict(start=(0.5, 0)), ValueError, "start"),
    (_grid, (), dict(goal=(3, -1)), ValueError, "goal"),
    (_grid, (), dict(slip=1.5), ValueError, "slip"),
    (_grid, (), dict(slip=float("nan")), ValueError, "slip"),
    (_grid, (), dict(miss_penalty=-50), ValueError, "miss_penalty"),
    (_grid, (), dict(miss_penalty=float("inf")), ValueError, "miss_penalty"),
    (_grid, (), dict(loiter="sometimes"), ValueError, "loiter"),
    (_grid, (), dict(horizon=0), ValueError, "horizon"),
    (chapter3, (), dict(layout="third"), ValueError, "layout"),
    # MDP
    (_mdp, (), dict(transitions=-np.ones((2, 1, 2))), ValueError, "transitions"),
    (_mdp, (), dict(transitions=np.full((2, 1, 2), 0.3)), ValueError, "sum to 1"),
    (_mdp, (), dict(transitions="S"), ValueError, "transitions"),
    (_mdp, (), dict(transitions=sp.csr_matrix(np.ones((3, 2)) / 2)), ValueError, "transitions"),
    (_mdp, (), dict(reward=np.array([[np.nan], [0.0]])), ValueError, "reward"),
    (_mdp, (), dict(reward=np.full((2, 1), 1e200)), ValueError, "exceeds"),
    (_mdp, (), dict(horizon=True), ValueError, "horizon"),
    (_mdp, (), dict(initial=np.array([0.7, 0.7])), ValueError, "initial"),
    (_mdp, (), dict(allowed=np.ones((2, 1))), ValueError, "allowed"),
    (_mdp, (), dict(allowed=np.array([[True], [False]])), ValueError, "offers no action"),
    # chance constraints (eqs. 3.1-3.2)
    (constraint_mask, (MDP0,), dict(states=[2.7]), ValueError, "states"),
    (constraint_mask, (MDP0,), dict(states=[99]), ValueError, "states"),
    (constraint_mask, (MDP0,), dict(states=[True]), ValueError, "states"),
    (constraint_mask, (MDP0,), dict(actions=[1.5]), ValueError, "actions"),
    (constraint_mask, (MDP0,), dict(actions=[9]), ValueError, "actions"),
    (constraint_mask, (MDP0,), dict(states=[1], psi=1.2), ValueError, "psi"),
    (constraint_mask, (MDP0,), dict(states=[1], psi=float("nan")), ValueError, "psi"),
    (constraint_mask, (MDP0,), dict(states=[1], psi="high"), ValueError, "psi"),
    (chance_forbidden, (MDP0, [1, 2], [0.1, 0.2, 0.3]), {}, ValueError, "psi"),
    # demonstrations
    (Demonstrations, (np.zeros((2, 3), dtype=int), np.zeros((2, 3), dtype=int)), {}, ValueError, "states/actions"),
    (Demonstrations, (np.zeros((1, 3)), np.zeros((1, 2))), {}, ValueError, "integer"),
    (check_demonstrations, (MDP0, Demonstrations(np.array([[0, 1]]), np.array([[12]]))), {}, ValueError, "unknown action"),
    (check_demonstrations, (MDP0, "demos"), {}, TypeError, "demos"),
    (_off_goal_loiter, (), {}, ValueError, "not available"),
    (sample_demonstrations, (MDP0, 0), {}, ValueError, "n"),
    (sample_demonstrations, (MDP0, True), {}, ValueError, "n"),
    (sample_demonstrations, (MDP0, 3, constraint_mask(MDP0, [5], 0.0)), {}, ValueError, "no trajectory"),
    # greedy inference (Section 2.4)
    (_greedy, (), dict(min_gain=float("nan")), ValueError, "min_gain"),
    (_greedy, (), dict(min_gain=float("inf")), ValueError, "min_gain"),
    (_greedy, (), dict(min_gain="0.1"), ValueError, "min_gain"),
    (_greedy, (), dict(rounds=-1), ValueError, "rounds"),
    (_greedy, (), dict(rounds=2.5), ValueError, "rounds"),
    (_greedy, (), dict(criterion="best"), ValueError, "criterion"),
    (_greedy, (), dict(criterion="likelihood", prune=True), ValueError, "prune"),
    (_greedy, (), dict(prune="yes"), TypeError, "prune"),
    (_greedy, (), dict(candidates="all"), TypeError, "candidates"),
    (_greedy, (), dict(engine="gpu"), ValueError, "engine"),
    (_greedy, (), dict(mdp=[MDP0, MDP0], demos=[DEMOS]), ValueError, "pooled"),
    (_greedy, (), dict(mdp=[MDP0, gridworld(5, 4, (0, 0), (4, 0)).mdp], demos=[DEMOS, DEMOS]), ValueError, "demonstrations"),
    (constraint_candidates, (MDP0, DEMOS), dict(chance="yes"), TypeError, "chance"),
    (horizon_sensitivity, (lambda T: G, [], MDP0.allowed, 5, 0, 1), {}, ValueError, "horizons"),
    # backups (Algorithms 3-4)
    (log_partition, (MDP0, np.ones((3, A, 2), dtype=bool)), {}, ValueError, "masks"),
    (log_partition, (MDP0, np.ones((X, A))), {}, ValueError, "masks"),
    (log_partition, (MDP0, np.ones((X, A), dtype=bool)), dict(engine="gpu"), ValueError, "engine"),
    (rank_candidates, (MDP0, DEMOS, np.ones((X, A - 1, 2), dtype=bool)), {}, ValueError, "forbidden"),
    (rank_candidates, (MDP0, DEMOS, CAND.forbidden, np.zeros((X, A), dtype=bool)), {}, ValueError, "base_mask"),
    (soft_bellman_backup, (MDP0, np.ones((X, A, 2), dtype=bool)), {}, ValueError, "mask"),
    (power_law_exponent, ([1.0], [1.0]), {}, ValueError, "sizes/cost"),
    # explore
    (inference_round_view, (), dict(round=0), ValueError, "round"),
    (inference_run, (), dict(n_demos=0), ValueError, "n_demos"),
    # the demonstrations CSV: file, line and column
    (_empty_file, (), {}, ValueError, "is empty"),
    (_load_edited, (lambda lines: lines[:1],), {}, ValueError, "no data rows"),
    (_load_edited, (lambda lines: [line.rsplit(",", 1)[0] for line in lines],), {}, ValueError, "missing column 'action'"),
    (_load_edited, (_replace(4, "action", "north"),), {}, ValueError, "line 4, column 'action'"),
    (_load_edited, (_replace(10, "action", "99"),), {}, ValueError, "last row"),
    (_load_edited, (_replace(5, "state", "2.5"),), {}, ValueError, "line 5, column 'state'"),
    (_load_edited, (_replace(5, "state", "99"),), {}, ValueError, "unknown state"),
    (_load_edited, (_replace(3, "t", "7"),), {}, ValueError, "column 't'"),
    (_load_edited, (_replace(3, "action", ""),), {}, ValueError, "line 3, column 'action': empty"),
    (_load_edited, (lambda lines: [lines[0]] + [line.replace("1,", "5,", 1) if line.startswith("1,") else line
                                               for line in lines[1:]],), {}, ValueError, "demo ids"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i:02d}-{case[0].__name__}" for i, case in enumerate(CASES)])
def test_bad_input_raises_a_clear_error(fn, args, kwargs, error, phrase):
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value), f"message {str(info.value)!r} should mention {phrase!r}"


def test_loader_messages_name_the_file():
    path = _written()
    df = pd.read_csv(path)
    df.loc[2, "action"] = np.nan
    df.to_csv(path, index=False)
    with pytest.raises(ValueError, match=str(path.name)):
        load_demonstrations(path, MDP0)


def test_soft_policy_stays_normalised_for_huge_penalties():
    # rows used to sum to 2.7 at a penalty of 1e16; relative to the row maximum they sum to 1
    from mutual.constraints.mdp import soft_policy
    for penalty in (1e12, 1e16, 1e90):
        g = gridworld(4, 4, (0, 0), (3, 0), miss_penalty=penalty)
        pi = soft_policy(g.mdp)
        live = pi.sum(axis=2) > 0
        np.testing.assert_allclose(pi.sum(axis=2)[live], 1.0, atol=1e-12)
        assert live.all() and np.all(np.isfinite(pi))
