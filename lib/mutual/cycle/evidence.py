"""Show, in the continuous loop: a Dubins car (eq. 7.5) whose motion evidences that it avoids the
supervisor's safe set (chapter 7), with iLQR, and the supervisor's posterior over time.

Hypotheses (chapter 7's structure, eqs. 7.3-7.4, with the learned safe set in place of the hazard):

    J0(u) = a_goal |P x_N - g|^2 + a_effort dt sum_k u_k^2                  (H0: ignorant of the set)
    J1(u) = J0(u) + a_safe dt sum_k softplus_s(level - V(x_k))^2             (H1: avoids {V < level})

where V is the avoid value of eq. (4.3) for a Dubins car with turn rate ``w_max`` around the disk
obstacle (the closed form in JAX, :func:`mutual.dubins.avoid_value_jax`, so iLQR can differentiate it;
its kinks rounded at width ``smoothing``) and softplus_s(z) = s log(1 + e^{z / s}) a smooth hinge. The legible robot minimises
(1 + alpha) J1 - J0 (eq. 6.15), the same feature cost with weights (1 + alpha) w1 - w0.
"""

from dataclasses import dataclass, replace

import jax.numpy as jnp
import numpy as np
import pandas as pd

from scipy import stats

from ..dubins import SPEED, TRUE_W_MAX, step_jax
from ..dubins import avoid_value_jax as avoid_value  # the closed form in JAX, kinks rounded
from ..supervision import avoid_value_closed_form
from .laplace import best_tail, posterior_over_time, prefix_log_likelihoods


def softplus(z, s):
    """s log(1 + exp(z / s)): a smooth max(z, 0) with corner width ``s`` (overflow-safe)."""
    return s * jnp.logaddexp(0.0, z / s)


def _dynamics(x, u, params):
    return step_jax(x, u, params["dt"], params["speed"])


def _running(x, u, params):
    w = params["weights"]
    value = avoid_value(x, params["w_max"], params["radius"], params["speed"], params["smoothing"])
    inside = softplus(params["level"] - value, params["softness"])
    return params["dt"] * (w[1] * jnp.sum(u ** 2) + w[2] * inside ** 2)


def _terminal(x, params):
    return params["weights"][0] * jnp.sum((x[:2] - params["goal"]) ** 2)


PROBLEM = (_dynamics, _running, _terminal)


@dataclass(frozen=True)
class SafeSetTask:
    """A car drives from ``x0`` (x, y, theta) to ``goal`` past a disk obstacle of ``radius`` at the
    origin in ``horizon`` seconds split into ``steps``; weights ``a_goal``, ``a_effort``, ``a_safe``,
    the hinge's corner ``softness`` and the width ``smoothing`` of V's rounded kinks (module docstring)."""

    x0: tuple
    goal: tuple
    horizon: float
    steps: int
    a_goal: float
    a_effort: float
    a_safe: float
    softness: float = 0.05
    smoothing: float = 0.02
    radius: float = 1.0
    speed: float = SPEED

    def __post_init__(self):
        if np.shape(self.x0) != (3,) or np.shape(self.goal) != (2,):
            raise ValueError("x0/goal: need a Dubins state (x, y, theta) and a planar goal (x, y)")
        for name in ("horizon", "a_goal", "a_effort", "softness", "smoothing", "radius", "speed"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"{name}: must be a positive finite number, got {getattr(self, name)!r}")
        if not (np.isfinite(self.a_safe) and self.a_safe >= 0):
            raise ValueError(f"a_safe: must be a non-negative finite number, got {self.a_safe!r}")
        if not isinstance(self.steps, (int, np.integer)) or self.steps < 1:
            raise ValueError(f"steps: must be a positive integer, got {self.steps!r}")

    @property
    def dt(self):
        return self.horizon / self.steps

    def params(self, w_max=TRUE_W_MAX, level=0.0, weights=None):
        """The traced parameters of the costs; ``weights`` (a_goal, a_effort, a_safe) default to H1's."""
        w = np.array([self.a_goal, self.a_effort, self.a_safe] if weights is None else weights, dtype=float)
        if not (np.isfinite(w_max) and w_max > 0 and np.isfinite(level)):
            raise ValueError(f"w_max/level: need a positive turn rate and a finite level, got {w_max!r}, {level!r}")
        return {"weights": w, "goal": np.asarray(self.goal, float), "w_max": np.float64(w_max),
                "level": np.float64(level), "radius": np.float64(self.radius), "softness": np.float64(self.softness),
                "smoothing": np.float64(self.smoothing),
                "dt": np.float64(self.dt), "speed": np.float64(self.speed)}

    def hypotheses(self, w_max, level, alpha):
        """Parameters of H0 (no safe-set term), H1 (avoid {V_w_max < level}) and the legible
        (1 + alpha) J1 - J0 (eq. 6.15)."""
        w1 = np.array([self.a_goal, self.a_effort, self.a_safe])
        w0 = np.array([self.a_goal, self.a_effort, 0.0])
        return {"H0": self.params(w_max, level, w0), "H1": self.params(w_max, level, w1),
                "legible": self.params(w_max, level, (1 + alpha) * w1 - w0)}


def turn_guesses(task, rates=(0.0, 0.5, -0.5, 1.0, -1.0)):
    """Constant turn-rate starting controls (N, 1) for multi-start iLQR (both ways around the obstacle)."""
    return [np.full((task.steps, 1), r) for r in rates]


# the safe-set term has kinks (the closed-form V is a max of branches), where iLQR's last digits crawl
ILQR_OPTIONS = {"grad_tol": 1e-6, "max_iter": 500, "second_order": True}


def solve_path(task, params, guesses=None):
    """The lowest-cost iLQR optimum of the task's cost with ``params`` over the starting controls
    (default :func:`turn_guesses`), as an ILQRResult with states (N+1, 3). Solved as the padded problem
    of :mod:`mutual.cycle.laplace` from stage 0, so paths and the observer's tails share one compiled iLQR."""
    best = best_tail(*PROBLEM, np.asarray(task.x0, float), 0, params, guesses or turn_guesses(task), **ILQR_OPTIONS)
    return replace(best, xs=best.xs[:, :-1], K=best.K[:, :, :-1])


def first_crossing(xs, dt, value, level):
    """The first time (s) at which ``value(x)`` (numpy, (n, 3) -> (n,)) falls to ``level`` along the
    states ``xs`` (N+1, 3), linearly interpolated between steps; inf if it never does."""
    v = np.asarray(value(np.asarray(xs, float)), float)
    below = np.flatnonzero(v <= level)
    if below.size == 0:
        return np.inf
    k = int(below[0])
    if k == 0:
        return 0.0
    return dt * (k - 1 + (v[k - 1] - level) / (v[k - 1] - v[k]))


def first_confidence(posterior, dt, level=0.95):
    """The first time (s) at which the posterior over time (N+1,) reaches ``level``; inf if never."""
    hit = np.flatnonzero(np.asarray(posterior) >= level)
    return dt * int(hit[0]) if hit.size else np.inf


def evidence_study(task, fitted, supervisor, alpha, observers=None, prior=0.5, level=0.95):
    """Step 6 of the cycle: iLQR paths of H0, H1 and the legible robot for ``fitted = (w_max, level)``
    (the robot's model of the supervisor's safe set), and each observer's posterior over time.

    ``supervisor``: ``(w_max, mu, sigma)`` of the simulated supervisor (their own safe set, unknown to the
    robot). ``observers``: {name: (w_max, level)} of the H1 each observer tests against H0 (default: the
    fitted set). Returns ``(paths, table, posteriors)``: the ILQRResults, one row per (observer, robot)
    with the time (s) the posterior first reaches ``level``, the time an ignorant robot (H0's path) first
    reaches the supervisor's level ``V_S <= mu``, the lead time (their difference; positive: confident
    before the supervisor must act), the final posterior, the robot's closest value of V_S and its
    probability of drawing an intervention Phi((mu - min V_S) / sigma); posteriors {(observer, robot): (N+1,)}.
    """
    hyp = task.hypotheses(*fitted, alpha)
    paths = {name: solve_path(task, params) for name, params in hyp.items()}
    w_s, mu_s, sigma_s = supervisor

    def v_s(xs):
        return avoid_value_closed_form(xs, w_s, task.radius, task.speed)

    crossing = first_crossing(paths["H0"].xs, task.dt, v_s, mu_s)
    rows, posteriors = [], {}
    for observer, (w_max, lvl) in (observers or {"fitted set": fitted}).items():
        h = task.hypotheses(w_max, lvl, alpha)
        own = {name: solve_path(task, h[name]) for name in ("H0", "H1")}
        for robot in ("H1", "legible"):
            ll = {name: prefix_log_likelihoods(*PROBLEM, np.asarray(task.x0, float), paths[robot].us, h[name],
                                               guesses=[own[name].us], **ILQR_OPTIONS) for name in ("H0", "H1")}
            post = posterior_over_time(ll["H1"], ll["H0"], prior)
            posteriors[observer, robot] = post
            confident = first_confidence(post, task.dt, level)
            lowest = float(v_s(paths[robot].xs).min())
            rows.append({"observer": observer, "robot": "plain (H1)" if robot == "H1" else robot,
                         "time_to_confidence": confident, "ignorant_reaches_level": crossing,
                         "lead_time": crossing - confident, "final_posterior": float(post[-1]),
                         "min_V_S": lowest, "p_intervention": float(stats.norm.cdf((mu_s - lowest) / sigma_s)),
                         "max_turn_rate": float(np.abs(paths[robot].us).max())})
    return paths, pd.DataFrame(rows), posteriors
