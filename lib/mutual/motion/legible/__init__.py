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

from .lqr import LQSolution, solve_lq
from .objective import (distractor_mixture, geometric_alpha_schedule, inverse_square_alpha_schedule, legible_cost,
                        legible_trajectory, linear_alpha_schedule, receding_horizon, replan_gains)
from .problem import (LinearDynamics, QuadraticCost, double_integrator, random_lq_hypotheses, reaching_cost,
                      single_integrator, solve)

__all__ = ["LQSolution", "LinearDynamics", "QuadraticCost", "distractor_mixture", "double_integrator",
           "geometric_alpha_schedule", "inverse_square_alpha_schedule", "legible_cost", "legible_trajectory", "linear_alpha_schedule",
           "multi_distractor_qp", "random_lq_hypotheses", "reaching_cost", "receding_horizon", "receding_horizon_qp",
           "replan_gains", "single_integrator", "solve", "solve_lq"]


def __getattr__(name):
    """The QP solvers load cvxpy, so :mod:`.qp` is imported on first use (a plain LQ solve needs only NumPy)."""
    if name in ("multi_distractor_qp", "receding_horizon_qp"):
        from . import qp
        return getattr(qp, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
