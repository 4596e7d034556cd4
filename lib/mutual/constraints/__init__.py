"""Thrust 1, chapters 2-3: learning a demonstrator's constraints from stochastic demonstrations.

Maximum-causal-entropy MDPs (:mod:`.mdp`), demonstrations (:mod:`.demonstrations`), the gridworld
of Section 3.3 (:mod:`.gridworld`), chance constraints and their thresholds (:mod:`.chance`,
eq. 3.3), the backups of Algorithms 1-4 (:mod:`.backup`, compiled for grids in :mod:`.fast`),
the candidate constraints (:mod:`.candidates`) and greedy inference (:mod:`.inference`, with the
pruning bound of :mod:`.bounds`). The same from continuous demonstrations -- an extension, Section
3.4's next step -- is the subpackage :mod:`.continuous`.
"""

from .backup import log_partition, rank_candidates, value_ratio
from .candidates import Candidates, constraint_candidates
from .chance import constraint_mask, max_likelihood_thresholds
from .demonstrations import Demonstrations, load_demonstrations, sample_demonstrations, write_demonstrations
from .gridworld import Gridworld, gridworld
from .inference import InferenceResult, greedy_inference
from .mdp import MDP, soft_bellman_backup, soft_policy

__all__ = ["MDP", "Candidates", "Demonstrations", "Gridworld", "InferenceResult", "constraint_candidates",
           "constraint_mask", "greedy_inference", "gridworld", "load_demonstrations", "log_partition",
           "max_likelihood_thresholds", "rank_candidates", "sample_demonstrations", "soft_bellman_backup",
           "soft_policy", "value_ratio", "write_demonstrations"]
