"""The settings of an iLQR solve as one value, in the shape of hj_reachability's ``SolverSettings``.

:class:`ILQRSettings` is frozen and checked when made, so a solve, a batch and the notebooks pass one
value instead of nine keywords. Its two static fields (``max_iter``, ``second_order``) choose the
compiled program; the seven tolerances travel into it as one array (:attr:`ILQRSettings.tolerances`,
read there as a :class:`Tolerances`), so changing a tolerance (e.g. ``target``, per problem) never
compiles anew. The tests they set are those of :mod:`.iteration`::

    settings = ILQRSettings(grad_tol=1e-8, second_order=True)
    ilqr(dynamics, running_cost, terminal_cost, x0, us0, params, settings)
    ilqr(dynamics, running_cost, terminal_cost, x0, us0, params, max_iter=500)   # the same, one field changed
"""

import dataclasses
from functools import cached_property
from typing import NamedTuple

import numpy as np


class Tolerances(NamedTuple):
    """The traced tolerances inside the compiled solve (:attr:`ILQRSettings.tolerances` unpacked):
    ``divergence_bound`` is inf and ``target`` -inf where they are off."""

    grad_tol: float
    stall_tol: float
    step_tol: float
    reg_max: float
    divergence_ratio: float
    divergence_bound: float
    target: float


def _number(value):
    return not isinstance(value, (bool, np.bool_)) and isinstance(value, (int, float, np.integer, np.floating))


@dataclasses.dataclass(frozen=True)
class ILQRSettings:
    """How :func:`mutual.motion.trajopt.ilqr` stops and how hard it tries (the scale-free tests of
    :mod:`.iteration`; ``M`` is the objective's magnitude, the sum of the absolute stage costs).

    ``max_iter``: backward passes at most. ``grad_tol``: converged when the model's predicted decrease
    ``1/2 g'H^-1 g`` is at most ``grad_tol**2 M``. ``stall_tol``, ``step_tol``: converged when an accepted
    step lowered the cost by at most ``stall_tol M`` and moved no control by more than ``step_tol`` times the
    largest control. ``reg_max``: fail when the regularisation ``mu`` (relative to the control curvature)
    needed exceeds it. ``divergence_ratio``: diverged when the cost falls below the start's by more than this
    times the start's scale; ``divergence_bound``: also when a state or control exceeds it (None: off).
    ``second_order``: False for Gauss-Newton iLQR, True for DDP, ``"auto"`` (Gauss-Newton far from the
    minimum, DDP close to it). ``target``: also stop at the first accepted step whose cost is at most this
    (NLopt's ``stopval``; None: off).

    Made with a wrong value, it raises a ValueError naming the field. ``settings.replace(max_iter=500)``
    is a copy with fields changed.
    """

    max_iter: int = 200
    grad_tol: float = 1e-6
    stall_tol: float = 1e-12
    step_tol: float = 1e-8
    reg_max: float = 1e10
    divergence_ratio: float = 1e8
    divergence_bound: float | None = None
    second_order: bool | str = "auto"
    target: float | None = None

    def __post_init__(self):
        if not (_number(self.max_iter) and isinstance(self.max_iter, (int, np.integer)) and self.max_iter >= 1):
            raise ValueError(f"max_iter must be a positive integer, got {self.max_iter!r}")
        for name in ("grad_tol", "stall_tol", "step_tol", "reg_max", "divergence_ratio"):
            value = getattr(self, name)
            if not (_number(value) and np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive finite number, got {value!r}")
        if self.divergence_bound is not None and not (_number(self.divergence_bound) and self.divergence_bound > 0):
            raise ValueError(f"divergence_bound must be None or a positive number, got {self.divergence_bound!r}")
        if self.target is not None and not (_number(self.target) and np.isfinite(self.target)):
            raise ValueError(f"target must be None or a finite number, got {self.target!r}")
        order = self.second_order
        if not (isinstance(order, (bool, np.bool_)) or (isinstance(order, str) and order == "auto")):
            raise ValueError(f"second_order must be True, False or 'auto', got {order!r}")
        object.__setattr__(self, "max_iter", int(self.max_iter))
        object.__setattr__(self, "second_order", order if isinstance(order, str) else bool(order))

    def replace(self, **changes):
        """A copy with the fields ``changes`` changed (checked like a new one)."""
        unknown = sorted(set(changes) - {f.name for f in dataclasses.fields(self)})
        if unknown:
            raise TypeError(f"unknown iLQR setting(s) {', '.join(unknown)}; the settings are "
                            f"{', '.join(f.name for f in dataclasses.fields(self))}")
        return dataclasses.replace(self, **changes) if changes else self

    @cached_property
    def tolerances(self):
        """The seven tolerances as one float64 array in the order of :class:`Tolerances` (what the compiled
        solve is given: one transfer, and no new compilation when a value changes)."""
        bound = np.inf if self.divergence_bound is None else self.divergence_bound
        target = -np.inf if self.target is None else self.target
        return np.array([self.grad_tol, self.stall_tol, self.step_tol, self.reg_max, self.divergence_ratio, bound,
                         target], dtype=np.float64)


DEFAULT = ILQRSettings()
BATCH_DEFAULT = ILQRSettings(second_order=False)  # a batched pass computes the curvature for all if any needs it
