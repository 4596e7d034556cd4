"""Chapter 8's closing cycle (Figure 8.1), run end to end on simulated humans: machines learn human
models of safety (chapters 2-5), robots act on them and show what they learned (chapters 6-7).

The discrete loop (gridworld): what a policy does, exactly (:mod:`.outcomes`); inference with a
stopping rule from one or several tasks (:mod:`.learning`); the human observer's likelihood-ratio
test between maximum-causal-entropy models (:mod:`.observer`); the MDP counterpart of chapter 6's
legible objective (:mod:`.mdp_legibility`); the loop's studies (:mod:`.discrete`).
The continuous loop (supervision): fit a noisy supervisor and act at mu + 2 sigma (:mod:`.supervision`);
iLQR motion that evidences the learned safe set (:mod:`.evidence`) and the supervisor's posterior over
time by the Laplace approximation (:mod:`.laplace`). Intervals in :mod:`.intervals`, figures in
:mod:`.plots`, interactive views in :mod:`.explore`.
"""

from .discrete import alpha_sweep, blind_spot_study, compare_robots, legible_robots, observer_study
from .evidence import SafeSetTask, evidence_study, solve_path
from .laplace import posterior_over_time, prefix_log_likelihoods
from .learning import ConstraintSet, pooled_inference, relevance, sample_efficiency, stop_threshold
from .mdp_legibility import legibility_weights, legible_backup, legible_objective
from .observer import expected_log_odds, posterior_paths, step_log_ratio, time_to_confidence
from .outcomes import policy_outcomes, sample_rollouts
from .supervision import closed_form_library, false_positive_study, learned_false_positives

__all__ = ["ConstraintSet", "SafeSetTask", "alpha_sweep", "blind_spot_study", "closed_form_library",
           "compare_robots", "evidence_study", "expected_log_odds", "false_positive_study", "learned_false_positives",
           "legibility_weights", "legible_backup", "legible_objective", "legible_robots", "observer_study",
           "policy_outcomes", "pooled_inference", "posterior_over_time", "posterior_paths",
           "prefix_log_likelihoods", "relevance", "sample_efficiency", "sample_rollouts", "solve_path",
           "step_log_ratio", "stop_threshold", "time_to_confidence"]
