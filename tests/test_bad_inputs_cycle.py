"""Bad inputs to mutual.cycle: each public function raises a ValueError naming the argument and why."""

import numpy as np
import pytest

from mutual.constraints.demonstrations import Demonstrations
from mutual.constraints.gridworld import gridworld
from mutual.cycle import explore
from mutual.cycle.evidence import SafeSetTask
from mutual.cycle.intervals import mean_interval
from mutual.cycle.laplace import posterior_over_time, prefix_log_likelihoods
from mutual.cycle.learning import ConstraintSet, concatenate, pooled_inference, stop_threshold
from mutual.cycle.mdp_legibility import legibility_weights, legible_backup, legible_objective
from mutual.cycle.observer import expected_log_odds, log_odds_paths, step_log_ratio, time_to_confidence
from mutual.cycle.outcomes import policy_outcomes, sample_rollouts
from mutual.cycle.supervision import closed_form_library, closed_form_value_function, collect_interventions

GRID = gridworld(3, 3, start=(0, 0), goal=(2, 0), slip=0.1, horizon=4)
MDP = GRID.mdp
T, X, A = MDP.horizon, MDP.n_states, MDP.n_actions
UNIFORM = np.full((T, X, A), 1.0 / A)
RATIO = np.zeros((T, X, A))
MASK = np.ones((X, A), dtype=bool)
DEMOS = Demonstrations(np.full((2, T + 1), GRID.state(*GRID.goal)), np.full((2, T), 8))      # loiter at the goal
OTHER_GRID = gridworld(4, 4, start=(0, 0), goal=(3, 0), horizon=4)
OTHER, OTHER_DEMOS = OTHER_GRID.mdp, Demonstrations(np.full((2, 5), OTHER_GRID.state(3, 0)), np.full((2, 4), 8))
TASK = dict(x0=(-7.5, -0.5, 0.0), goal=(7.5, -0.5), horizon=5.0, steps=10, a_goal=10.0, a_effort=2.0, a_safe=100.0)

CASES = [
    (policy_outcomes, (MDP, UNIFORM[:-1]), {}, ValueError, "policy: shape"),
    (policy_outcomes, (MDP, -UNIFORM), {}, ValueError, "non-negative"),
    (policy_outcomes, (MDP, 2 * UNIFORM), {}, ValueError, "sum to 1"),
    (policy_outcomes, (MDP, UNIFORM), {"allowed": np.ones((X, A))}, ValueError, "allowed: must be a boolean"),
    (policy_outcomes, (MDP, UNIFORM), {"forbidden_states": [X]}, ValueError, "forbidden_states"),
    (sample_rollouts, (MDP, UNIFORM, 0), {}, ValueError, "n: must be a positive integer"),
    (sample_rollouts, (MDP, UNIFORM[:, :, :-1], 3), {}, ValueError, "policy: shape"),
    (step_log_ratio, (MDP, np.ones((X, A))), {}, ValueError, "mask_h1"),
    (step_log_ratio, (MDP, MASK, np.ones((X, A + 1), bool)), {}, ValueError, "mask_h0"),
    (log_odds_paths, (RATIO, DEMOS), {"prior": 1.0}, ValueError, "prior"),
    (log_odds_paths, (RATIO[:, :, :3], DEMOS), {}, ValueError, "step_ratio"),
    (time_to_confidence, (np.zeros((1, 3)), 1.0), {}, ValueError, "level"),
    (expected_log_odds, (MDP, UNIFORM, RATIO[:-1]), {}, ValueError, "step_ratio"),
    (expected_log_odds, (MDP, UNIFORM, RATIO), {"prior": 0.0}, ValueError, "prior"),
    (expected_log_odds, (MDP, UNIFORM, RATIO + np.inf), {}, ValueError, "H0's support"),
    (legibility_weights, (0,), {}, ValueError, "horizon"),
    (legibility_weights, (4, "early"), {}, ValueError, "kind"),
    (legible_backup, (MDP, MASK, RATIO, 0.0, np.ones(T)), {}, ValueError, "alpha"),
    (legible_backup, (MDP, MASK, RATIO, 1.0, np.ones(T + 1)), {}, ValueError, "weights"),
    (legible_backup, (MDP, MASK, RATIO[1:], 1.0, np.ones(T)), {}, ValueError, "step_ratio: shape"),
    (legible_backup, (MDP, MASK, RATIO + np.inf, 1.0, np.ones(T)), {}, ValueError, "step_ratio: must be finite"),
    (legible_backup, (MDP, np.ones((X, A, 2), bool), RATIO, 1.0, np.ones(T)), {}, ValueError, "mask"),
    (legible_objective, (MDP, UNIFORM, RATIO, 1.0, np.ones(T - 1)), {}, ValueError, "weights"),
    (ConstraintSet, ((1, 2), 1.5), {}, ValueError, "psi"),
    (stop_threshold, (1.0,), {}, ValueError, "level"),
    (concatenate, ([],), {}, ValueError, "demos_list"),
    (pooled_inference, ([],), {}, ValueError, "tasks"),
    (pooled_inference, ([(MDP, DEMOS)],), {"max_rounds": -1}, ValueError, "max_rounds"),
    (pooled_inference, ([(MDP, DEMOS), (OTHER, OTHER_DEMOS)],), {}, ValueError, "share"),
    (mean_interval, ([1.0, 2.0],), {"method": "jackknife"}, ValueError, "method"),
    (mean_interval, ([1.0, 2.0],), {"level": 1.5}, ValueError, "level"),
    (posterior_over_time, ([0.0], [0.0]), {"prior": 1.0}, ValueError, "prior"),
    (prefix_log_likelihoods, (None, None, None, np.zeros(2), np.zeros(3), {}), {}, ValueError, "us: must have shape"),
    (SafeSetTask, (), dict(TASK, x0=(0.0, 0.0)), ValueError, "x0/goal"),
    (SafeSetTask, (), dict(TASK, horizon=-1.0), ValueError, "horizon"),
    (SafeSetTask, (), dict(TASK, steps=0), ValueError, "steps"),
    (SafeSetTask, (), dict(TASK, a_safe=-1.0), ValueError, "a_safe"),
    (SafeSetTask(**TASK).params, (), {"w_max": 0.0}, ValueError, "w_max/level"),
    (closed_form_library, ([1.0, 1.0], 1.0), {}, ValueError, "w_maxes"),
    (closed_form_library, ([-1.0], 1.0), {}, ValueError, "w_maxes"),
    (closed_form_value_function, (1.0, 1.0, "grid"), {}, ValueError, "grid_spec"),
    (collect_interventions, (None, 0, None, 7.5), {}, ValueError, "n: must be a positive integer"),
    (explore.discrete_view, (), {"n_demos": 0}, ValueError, "n_demos"),
    (explore.discrete_view, (), {"alpha": 0.0}, ValueError, "alpha"),
    (explore.continuous_view, (), {"n_interventions": 1}, ValueError, "n_interventions"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{c[0].__name__ if hasattr(c[0], '__name__') else 'call'}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase):
        fn(*args, **kwargs)
