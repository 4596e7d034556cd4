"""Trajectory optimisation for chapters 6-8: iterative LQR (Todorov & Li 2005) with Tassa, Erez &
Todorov's (2012) regularisation and line search, compiled with JAX, and the baselines it is
measured against.

One module per step of the algorithm, each read beside its paper: the problem and its rollout
(:mod:`.problem`), the local quadratic model (:mod:`.model`), the backward pass (:mod:`.backward`),
the line search (:mod:`.line_search`), the regularisation schedule and convergence tests
(:mod:`.iteration`), the compiled loop (:mod:`.compiled`) and the solver users call
(:mod:`.solver`: :func:`ilqr`, :func:`ilqr_batch`) with its settings as one value (:mod:`.settings`:
:class:`ILQRSettings`). Input checks in :mod:`.checks`; single shooting with L-BFGS, the baseline, in
:mod:`.single_shooting`; several starts in :mod:`.multistart`.
"""

from .multistart import MultiStart
from .single_shooting import solve_lbfgs_jit, solve_single_shooting
from .settings import ILQRSettings
from .solver import (ILQRBatch, ILQRError, ILQRResult, ilqr, ilqr_batch, iteration_flops, rollout, trajectory_cost,
                     trajectory_cost_grad)

__all__ = ["ILQRBatch", "ILQRError", "ILQRResult", "ILQRSettings", "MultiStart", "ilqr", "ilqr_batch", "iteration_flops",
           "rollout", "solve_lbfgs_jit", "solve_single_shooting", "trajectory_cost", "trajectory_cost_grad"]
