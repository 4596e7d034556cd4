"""Chapter 6: legible motion as hypothesis testing.

The LQ problem (:mod:`.problem`: linear dynamics, quadratic costs, eq. (6.17)'s reaching cost) and
its exact solution by the Riccati recursion (:mod:`.lqr`, compiled in :mod:`.lqr_compiled`); the
legible objective ``(1 + alpha) J1 - J0`` and its receding horizon (:mod:`.objective`, eqs.
(6.13)-(6.16)); several distractors as a QP (:mod:`.qp`); Dragan and Srinivasa's baseline
(:mod:`.dragan`); anticipation (:mod:`.anticipation`), predictability (:mod:`.predictability`),
path measures for Figures 6.2-6.3 (:mod:`.path_measures`, :mod:`.multigoal`), measured costs
(:mod:`.timing`), chapter 6's statements checked by independent routes (:mod:`.verify`) and the Explore views
(:mod:`.explore`). The Boltzmann observer of eq. (6.8) is shared with chapter 7:
:mod:`mutual.motion.observer`.
"""

from ...lazy import lazy_names
from .lqr import LQSolution, solve_lq
from .objective import (distractor_mixture, geometric_alpha_schedule, inverse_square_alpha_schedule, legible_cost,
                        legible_trajectory, linear_alpha_schedule, receding_horizon, replan_gains)
from .problem import (LinearDynamics, QuadraticCost, double_integrator, random_lq_hypotheses, reaching_cost,
                      single_integrator, solve)

_ON_FIRST_USE = {
    # the QP solvers load cvxpy (a plain LQ solve needs only NumPy)
    "multi_distractor_qp": "qp", "receding_horizon_qp": "qp",
    # chapter 6's figures and statements, measured and checked by independent routes
    "figure_62_scan": "anticipation", "receding_equivalence": "anticipation",
    "gradient_linear_structure": "dragan", "figure_63_verdicts": "multigoal", "time_to_reach": "path_measures",
    "correlation_scan": "predictability", "corollary_operation_counts": "timing", "replan_against_dragan": "timing",
    "lbfgs_likelihood_ratio_minimiser": "verify", "lemma_641_exhaustive": "verify",
    "suboptimality_multiplier": "verify",
}

__all__ = ["LQSolution", "LinearDynamics", "QuadraticCost", "corollary_operation_counts", "correlation_scan",
           "distractor_mixture", "double_integrator", "figure_62_scan", "figure_63_verdicts",
           "geometric_alpha_schedule", "gradient_linear_structure", "inverse_square_alpha_schedule",
           "lbfgs_likelihood_ratio_minimiser", "legible_cost", "legible_trajectory", "lemma_641_exhaustive",
           "linear_alpha_schedule", "multi_distractor_qp", "random_lq_hypotheses", "reaching_cost",
           "receding_equivalence", "receding_horizon", "receding_horizon_qp", "replan_against_dragan", "replan_gains",
           "single_integrator", "solve", "solve_lq", "suboptimality_multiplier", "time_to_reach"]

__getattr__ = lazy_names(__name__, _ON_FIRST_USE)
