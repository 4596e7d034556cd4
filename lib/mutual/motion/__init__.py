"""Thrust 2, chapters 6-7: robots informing humans through motion.

Legible motion as hypothesis testing: the LQ solver (:mod:`.lqr`), legible objectives and receding
horizons (:mod:`.legibility`, eqs. 6.13-6.16), the Boltzmann observer in closed form
(:mod:`.observer`, eq. 6.8), several distractors (:mod:`.qp`), Dragan and Srinivasa's baseline
(:mod:`.dragan`), anticipation and predictability (:mod:`.anticipation`, :mod:`.predictability`),
the compiled Riccati backend (:mod:`.lqr_compiled`), iLQR (:mod:`.ilqr`) and evident safety for the
Dubins car (:mod:`.evident_safety`).
"""

from .ilqr import ILQRResult, ilqr
from .legibility import (LinearDynamics, QuadraticCost, legible_trajectory, reaching_cost, receding_horizon,
                         single_integrator)
from .lqr import solve_lq
from .observer import log_likelihood_ratio, posterior_over_time
from .qp import multi_distractor_qp

__all__ = ["ILQRResult", "LinearDynamics", "QuadraticCost", "ilqr", "legible_trajectory", "log_likelihood_ratio",
           "multi_distractor_qp", "posterior_over_time", "reaching_cost", "receding_horizon", "single_integrator",
           "solve_lq"]
