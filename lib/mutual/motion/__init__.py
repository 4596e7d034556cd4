"""Thrust 2, chapters 6-7: robots informing humans through motion, laid out by chapter.

* :mod:`.legible` -- chapter 6: legible motion as hypothesis testing for LQ problems (LQR,
  receding horizon, the multi-distractor QP, anticipation, Dragan and Srinivasa's baseline);
* :mod:`.evident` -- chapter 7: evident safety on nonlinear dynamics (vehicle models, the
  feature-cost task, legible MPC, the belief over time);

and what both chapters use:

* :mod:`.observer` -- the Boltzmann observer of eq. (6.8) in closed form; :mod:`.belief` -- its
  belief over time (Gaussian prefix marginals, exact or Laplace);
* :mod:`.trajopt` -- iLQR (Todorov & Li 2005; Tassa et al. 2012), compiled with JAX, and its
  single-shooting baselines;
* :mod:`.spec` -- a legible-motion problem read from TOML (``mutual motion legible``), and
  :mod:`.animation` -- the belief animations of both chapters.
"""

from .legible import (LinearDynamics, QuadraticCost, legible_trajectory, multi_distractor_qp, reaching_cost,
                      receding_horizon, single_integrator, solve_lq)
from .observer import log_likelihood_ratio, posterior_over_time
from .trajopt import ILQRResult, ilqr

__all__ = ["ILQRResult", "LinearDynamics", "QuadraticCost", "ilqr", "legible_trajectory", "log_likelihood_ratio",
           "multi_distractor_qp", "posterior_over_time", "reaching_cost", "receding_horizon", "single_integrator",
           "solve_lq"]
