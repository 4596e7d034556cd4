"""Thrust 1, chapters 2-3: learning a demonstrator's constraints from stochastic demonstrations.

Maximum-causal-entropy MDPs (:mod:`.mdp`), demonstrations (:mod:`.demonstrations`), the gridworld
of Section 3.3 (:mod:`.gridworld`), chance constraints and their thresholds (:mod:`.chance`,
eq. 3.3), the backups of Algorithms 1-4 (:mod:`.backup`, compiled for grids in :mod:`.fast`),
the candidate constraints (:mod:`.candidates`) and greedy inference (:mod:`.inference`, with the
pruning bound of :mod:`.bounds`). The same from continuous demonstrations -- an extension, Section
3.4's next step -- is the subpackage :mod:`.continuous`.
"""

from ..lazy import lazy_names
from .backup import (algorithm_agreement, log_partition, log_partition_literal, rank_candidates,
                     state_action_visitation, value_ratio)
from .candidates import Candidates, as_tasks, constraint_candidates
from .chance import constraint_mask, lemma_321_exact, max_likelihood_thresholds, psi_star_by_loop
from .demonstrations import (Demonstrations, load_demonstrations, sample_demonstrations, sample_trajectories,
                             write_demonstrations)
from .gridworld import GRID_ACTIONS, Gridworld, gridworld
from .inference import InferenceResult, greedy_inference, score_candidates
from .mdp import MDP, check_mask, expected_next, masked_logsumexp, soft_bellman_backup, soft_policy

__all__ = ["GRID_ACTIONS", "MDP", "Candidates", "Demonstrations", "Gridworld", "InferenceResult",
           "algorithm_agreement", "as_tasks", "causal_versus_noncausal", "check_mask", "constraint_candidates",
           "constraint_mask", "controller_check", "expected_next", "gradient_check", "greedy_bound_survey",
           "greedy_inference", "gridworld", "gridworld_ranking_work", "lemma_321_exact", "load_demonstrations",
           "load_world", "log_partition", "log_partition_literal", "masked_logsumexp", "max_likelihood_thresholds",
           "plot_actions", "plot_states", "printed_gradient_check", "psi_star_by_loop", "rank_candidates",
           "sample_demonstrations", "sample_trajectories", "score_candidates", "soft_bellman_backup", "soft_policy",
           "state_action_visitation", "value_ratio", "write_demonstrations"]

# the world file, the figures and the independent checks of chapters 2-3, imported on first use
__getattr__ = lazy_names(__name__, {
    "load_world": "world", "plot_states": "plots", "plot_actions": "plots",
    "causal_versus_noncausal": "noncausal", "controller_check": "controllers", "gradient_check": "gradient",
    "printed_gradient_check": "gradient", "greedy_bound_survey": "subsets", "gridworld_ranking_work": "complexity"})
