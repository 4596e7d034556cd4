"""Thrust 2, chapters 6-7: robots informing humans through motion, laid out by chapter.

* :mod:`.legible` -- chapter 6: legible motion as hypothesis testing for LQ problems (LQR,
  receding horizon, the multi-distractor QP, anticipation, Dragan and Srinivasa's baseline);
* :mod:`.evident` -- chapter 7: evident safety on nonlinear dynamics (vehicle models, the
  feature-cost task, legible MPC, the belief over time);

and what both chapters use:

* :mod:`.observer` -- the Boltzmann observer of eq. (6.8) in closed form; :mod:`.chain` -- its
  density factored stage by stage (the Riccati factorisation, O(N) at any horizon);
  :mod:`.belief` -- its belief over time (Gaussian prefix marginals, exact or Laplace);
* :mod:`.trajopt` -- iLQR (Todorov & Li 2005; Tassa et al. 2012), compiled with JAX, and its
  single-shooting baselines;
* :mod:`.spec` -- a legible-motion problem read from TOML (``mutual motion legible``; the Dubins
  car in :mod:`.spec_dubins`), and
  :mod:`.animation` -- the belief animations of both chapters.
"""

from ..lazy import lazy_names
from .legible import (LinearDynamics, QuadraticCost, legible_trajectory, reaching_cost, receding_horizon,
                      single_integrator, solve_lq)
from .observer import log_likelihood_ratio, posterior_over_time

__all__ = ["ILQRError", "ILQRResult", "LinearDynamics", "QuadraticCost", "dubins_step", "ilqr", "laplace_gaussian",
           "legible_trajectory", "load_legible_spec", "log_likelihood_ratio", "multi_distractor_qp",
           "posterior_over_time", "reaching_cost", "receding_horizon", "single_integrator", "solve_legible", "solve_lq"]

# iLQR, the Dubins car and the Laplace belief load JAX and the QP cvxpy: they are imported on first use, so
# that the LQ path (chapter 6's solvers and observer, ``mutual motion legible`` on the single integrator)
# starts in NumPy alone
__getattr__ = lazy_names(__name__, {
    "ILQRError": "trajopt", "ILQRResult": "trajopt", "ilqr": "trajopt", "multi_distractor_qp": "legible.qp",
    "dubins_step": "evident.vehicles", "laplace_gaussian": "belief", "load_legible_spec": "spec",
    "solve_legible": "spec"})
