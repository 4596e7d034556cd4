"""Evident safety (chapter 7): legible avoidance for the single integrator, the Dubins car and the
kinematic bicycle.

Every hypothesis cost of chapter 7 is a weighted sum of four features of a trajectory,
discretised with ``N`` steps of ``dt = T / N`` (left Riemann sums, as
:mod:`mutual.motion.legible` does)::

    J(u; w) = w_goal   |P x_N - g|^2                                  (eqs. 7.1, 7.3)
            + w_effort dt sum_k |u_k|^2                                (eqs. 7.1, 7.3)
            - w_hazard dt sum_k |P x_k - h|^2                          (eqs. 7.2, 7.4)
            + w_keep   dt sum_k sum_s 1 / (1 + |P x_k - s|^2 / r^2)    (keep-out states s)

``P`` projects the state onto the plane. The last feature is a smooth potential field [59] over
keep-out states (a person in Fig. 6.1, or a constraint inferred in chapters 2-3), so a robot can
evidence that it respects a learned constraint. Costs are linear in the weights, so the legible
objective ``(1 + alpha) J1 - J0`` of eq. (6.15) is the same feature cost with weights
``(1 + alpha) w1 - w0`` (:func:`mutual.motion.legible.objective.legible_cost`): H0, H1 and the legible
problem share one compiled iLQR (:mod:`mutual.motion.trajopt`), and many of them are solved at once
by :func:`solve_batch` (multi-start, alpha sweeps).

Dynamics (:mod:`mutual.motion.evident.vehicles`), chosen by the length of the state: ``x' = u`` in the
plane (2, Fig. 7.1), the Dubins car of eq. (7.5) (3, Fig. 7.2), the kinematic bicycle
(4, Fig. 6.1).
"""

from dataclasses import dataclass, field

import jax.numpy as jnp
import numpy as np
import pandas as pd

from ...inputs import positive
from ..legible.objective import legible_cost
from ..legible.problem import QuadraticCost, reaching_cost
from ..trajopt import MultiStart, ilqr, ilqr_batch, solve_single_shooting, trajectory_cost, trajectory_cost_grad
from ..trajopt import rollout as _rollout
from .evidence import distance_to_point
from ...dubins import SPEED, step_jax
from .vehicles import WHEELBASE, bicycle_step, single_integrator_step

FEATURES = ("goal", "effort", "hazard", "keep_out")


def project(x):
    """``P x`` with ``P = [[1, 0, 0], [0, 1, 0]]`` (section 7.2): the planar position of a state,
    i.e. its first two coordinates (identity for ``x' = u`` in the plane; works on batches)."""
    return x[..., :2]


def hazard_term(p, hazard):
    """``|p - h|^2``: the squared distance from ``h`` that eq. (7.4) rewards with weight ``a3``."""
    return jnp.sum((p - hazard) ** 2, axis=-1)


def keep_out_penalty(p, states, radius):
    """Smooth keep-out penalty ``sum_s 1 / (1 + |p - s|^2 / r^2)`` over keep-out states ``s`` (K, 2).

    A potential field [59]: each keep-out state contributes a bump of height 1 and width ``radius``
    with a long (inverse-square) tail, so raising its weight, as the legible objective does, pushes
    the path visibly farther; no keep-out states give zero.
    """
    d2 = jnp.sum((p[..., None, :] - states) ** 2, axis=-1)
    return jnp.sum(1.0 / (1.0 + d2 / radius ** 2), axis=-1)


def _step(x, u, params):
    """The task's dynamics by state length: 2 ``x' = u``, 3 the Dubins car, 4 the bicycle."""
    dt = params["dt"]
    if x.shape[0] == 3:
        return step_jax(x, u, dt, params["speed"])
    if x.shape[0] == 4:
        return bicycle_step(x, u, dt, params["wheelbase"])
    return single_integrator_step(x, u, dt)


def _running(x, u, params):
    """Stage cost ``dt w . features`` (the goal feature is terminal only, so 0 here)."""
    w, p = params["weights"], project(x)
    features = jnp.stack([jnp.zeros(()), jnp.sum(u ** 2), -hazard_term(p, params["hazard"]),
                          keep_out_penalty(p, params["keep_out"], params["radius"])])
    return params["dt"] * w @ features


def _terminal(x, params):
    """Terminal cost ``a1 |P x_N - g|^2``."""
    return params["weights"][0] * jnp.sum((project(x) - params["goal"]) ** 2)


@dataclass(frozen=True)
class EvidentSafetyTask:
    """A planar reach task with something to keep away from (sections 7.1-7.2, Fig. 6.1).

    ``x0`` (2,) for ``x' = u``, (3,) ``(x, y, theta)`` for the Dubins car or (4,)
    ``(x, y, theta, v)`` for the kinematic bicycle; ``goal`` g and ``hazard`` h planar points;
    ``keep_out`` (K, 2) keep-out states with bump width ``radius``; ``horizon`` T (seconds)
    split into ``steps`` N; ``speed`` v of eq. (7.5); ``wheelbase`` L of the bicycle.
    """

    x0: np.ndarray
    goal: np.ndarray
    hazard: np.ndarray = field(default_factory=lambda: np.zeros(2))
    keep_out: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    radius: float = 1.0
    horizon: float = 1.0
    steps: int = 100
    speed: float = SPEED
    wheelbase: float = WHEELBASE

    def __post_init__(self):
        x0 = np.asarray(self.x0, float)
        if x0.shape not in ((2,), (3,), (4,)):
            raise ValueError(f"x0 must be a planar position (2,), a Dubins state (3,) or a bicycle state (4,), "
                             f"got shape {x0.shape}")
        for name, shape in (("goal", (2,)), ("hazard", (2,))):
            value = np.asarray(getattr(self, name), float)
            if value.shape != shape:
                raise ValueError(f"{name} must be a planar point of shape (2,), got shape {value.shape}")
            object.__setattr__(self, name, value)
        keep_out = np.asarray(self.keep_out, float) if np.size(self.keep_out) else np.zeros((0, 2))
        if keep_out.ndim != 2 or keep_out.shape[1] != 2:
            raise ValueError(f"keep_out must have shape (K, 2), got shape {np.shape(self.keep_out)}")
        for name, a in (("x0", x0), ("goal", self.goal), ("hazard", self.hazard), ("keep_out", keep_out)):
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{name} must be finite")
        for name in ("radius", "horizon", "speed", "wheelbase"):
            positive(name, getattr(self, name))
        if isinstance(self.steps, (bool, np.bool_)) or not (isinstance(self.steps, (int, np.integer))
                                                              and self.steps >= 1):
            raise ValueError(f"steps must be a positive integer, got {self.steps!r}")
        object.__setattr__(self, "x0", x0)
        object.__setattr__(self, "keep_out", keep_out)

    @property
    def dt(self):
        """Step length ``T / N``."""
        return self.horizon / self.steps

    @property
    def controls(self):
        """Number of controls: 2 for ``x' = u`` and the bicycle, 1 (the turn rate) for the Dubins car."""
        return 1 if self.x0.shape == (3,) else 2

    def params(self, weights):
        """The traced parameters of the feature cost for weight vector ``weights`` (see FEATURES)."""
        w = np.asarray(weights, float)
        if w.shape != (len(FEATURES),) or not np.all(np.isfinite(w)):
            raise ValueError(f"weights must be {len(FEATURES)} finite numbers {FEATURES}, got {weights!r}")
        # numpy float64 arrays: iLQR converts them under its 64-bit context
        return {"weights": w, "goal": self.goal, "hazard": self.hazard, "keep_out": self.keep_out,
                "radius": np.float64(self.radius), "dt": np.float64(self.dt), "speed": np.float64(self.speed),
                "wheelbase": np.float64(self.wheelbase)}

    def zero_controls(self):
        """The initial guess of every solve: no control (straight ahead at constant speed / stand still)."""
        return np.zeros((self.steps, self.controls))


def hypothesis_weights(goal, effort, hazard=0.0, keep_out=0.0):
    """Weights ``(a1, a2, a3, a4)`` of the feature cost: H0 of eqs. (7.1)/(7.3) has ``hazard = keep_out = 0``."""
    return np.array([goal, effort, hazard, keep_out], dtype=float)


def legible_weights(w1, w0, alpha):
    """Weights of ``(1 + alpha) J1 - J0`` (eq. (6.15)); costs are linear in their weights."""
    return legible_cost(np.asarray(w1, float), np.asarray(w0, float), alpha)


def problem(task, weights):
    """``(dynamics, running_cost, terminal_cost, x0, params)`` for :mod:`mutual.motion.trajopt`'s functions."""
    return _step, _running, _terminal, task.x0, task.params(weights)


def _literal_running(x, u, params):
    """``(1 + alpha) l1 - l0``: both hypotheses' stage costs evaluated and combined (Corollary 6.4.2.1)."""
    one, zero = {**params, "weights": params["w1"]}, {**params, "weights": params["w0"]}
    return (1 + params["alpha"]) * _running(x, u, one) - _running(x, u, zero)


def _literal_terminal(x, params):
    one, zero = {**params, "weights": params["w1"]}, {**params, "weights": params["w0"]}
    return (1 + params["alpha"]) * _terminal(x, one) - _terminal(x, zero)


def literal_legible_problem(task, w0, w1, alpha):
    """The legible objective ``(1 + alpha) J1 - J0`` as the corollary's proof states it: every query
    evaluates both hypotheses' costs and combines them (instead of merging their weights);
    ``(dynamics, running_cost, terminal_cost, x0, params)``, e.g. for
    :func:`mutual.motion.trajopt.iteration_flops`."""
    params = {**task.params(w1), "w0": np.asarray(w0, float), "w1": np.asarray(w1, float),
              "alpha": np.float64(alpha)}
    return _step, _literal_running, _literal_terminal, task.x0, params


def solve(task, weights, us0=None, **ilqr_options):
    """Minimise the feature cost with ``weights`` by iLQR from ``us0`` (default: zero controls)."""
    dyn, run, term, x0, params = problem(task, weights)
    us0 = task.zero_controls() if us0 is None else us0
    return ilqr(dyn, run, term, x0, us0, params, **ilqr_options)


def solve_batch(tasks, weights, us0=None, **ilqr_options):
    """Solve many feature-cost problems at once (:func:`mutual.motion.trajopt.ilqr_batch`).

    ``tasks`` one task or a sequence of B tasks of the same dynamics and ``steps`` (e.g. other
    start states, goals or hazards); ``weights`` (4,) or (B, 4) (e.g. an alpha sweep); ``us0``
    None (zero controls), (N, m) or (B, N, m). Returns an :class:`mutual.motion.trajopt.ILQRBatch`.
    """
    tasks = [tasks] if isinstance(tasks, EvidentSafetyTask) else list(tasks)
    if not tasks or not all(isinstance(t, EvidentSafetyTask) for t in tasks):
        raise ValueError("tasks must be an EvidentSafetyTask or a non-empty sequence of them")
    W = np.asarray(weights, float)
    B = max(len(tasks), len(W) if W.ndim == 2 else 1, 1 if us0 is None or np.ndim(us0) < 3 else len(us0))
    if W.ndim == 1:
        W = np.broadcast_to(W, (B, W.shape[0]))
    if len(tasks) == 1:
        tasks = tasks * B
    if len(tasks) != B or W.shape[0] != B:
        raise ValueError(f"tasks, weights and us0 must describe the same number of problems, got {len(tasks)} "
                         f"tasks, {W.shape[0]} weight vectors")
    shapes = {(t.x0.shape, t.steps, t.keep_out.shape) for t in tasks}
    if len(shapes) > 1:
        raise ValueError("tasks in a batch must share the dynamics, steps and number of keep-out states")
    params = [t.params(w) for t, w in zip(tasks, W)]
    stacked = {k: np.stack([p[k] for p in params]) for k in params[0]}
    us = np.zeros((B, tasks[0].steps, tasks[0].controls)) if us0 is None else np.asarray(us0, float)
    if us.ndim == 2:
        us = np.broadcast_to(us, (B,) + us.shape)
    return ilqr_batch(_step, _running, _terminal, np.stack([t.x0 for t in tasks]), us, stacked, **ilqr_options)


def rollout(task, us):
    """The states (N+1, n) that ``task``'s dynamics reach from ``task.x0`` under the controls ``us`` (N, m)."""
    return _rollout(_step, task.x0, us, task.params(np.zeros(len(FEATURES))))


def cost(task, weights, us):
    """The feature cost of the controls ``us`` (single shooting, eq. (6.6))."""
    dyn, run, term, x0, params = problem(task, weights)
    return trajectory_cost(dyn, run, term, x0, us, params)


def cost_gradient(task, weights, us):
    """``(cost, d cost / d us)`` by autodiff through the rollout."""
    dyn, run, term, x0, params = problem(task, weights)
    return trajectory_cost_grad(dyn, run, term, x0, us, params)


def solve_lbfgs(task, weights, us0=None, **options):
    """The same problem by scipy L-BFGS on the single-shooting objective; ``(us, cost, scipy_result)``."""
    dyn, run, term, x0, params = problem(task, weights)
    us0 = task.zero_controls() if us0 is None else us0
    return solve_single_shooting(dyn, run, term, x0, us0, params, **options)


# ---- the scenarios of Figs. 7.1, 7.2 and 6.1 ----------------------------------------------------

LEGIBLE_ALPHA = 0.5  # alpha of eq. (6.15) for every legible path here (the thesis gives none; see notebook)


def figure_scenario(figure, steps=100):
    """``(task, w0, w1)`` for ``"7.1"``, ``"7.2"`` or ``"6.1"``: the task and the weights of H0 and H1.

    Thesis values: Fig. 7.1 g = [2, -2], a1 = 40, a2 = 25, a3 = 1 with x' = u and h at the
    origin; Fig. 7.2 the Dubins car, g = [2, -1], h = [-2, 2] (the text's and the caption's
    parameter list; the caption's prose says [2, -2]), a1 = 800, a2 = 10, a3 = 2. Our choices
    (the thesis is silent): start states, horizons, N = ``steps``, and all of Fig. 6.1: a
    kinematic bicycle (wheelbase 1 m, 3 m/s) passing a person standing just off its straight
    course, who is modelled by seven keep-out states (a centre and a ring of radius 0.3); the
    task's ``hazard`` is the person's position, used only to measure distances, with weight 0.
    """
    if figure == "7.1":
        task = EvidentSafetyTask(x0=[-2.0, 1.0], goal=[2.0, -2.0], hazard=[0.0, 0.0], horizon=5.0, steps=steps)
        return task, hypothesis_weights(40, 25), hypothesis_weights(40, 25, hazard=1)
    if figure == "7.2":
        task = EvidentSafetyTask(x0=[-4.0, -2.0, np.pi / 2], goal=[2.0, -1.0], hazard=[-2.0, 2.0], horizon=2.5,
                                 steps=steps)
        return task, hypothesis_weights(800, 10), hypothesis_weights(800, 10, hazard=2)
    if figure == "6.1":
        person = np.array([0.0, 0.25])
        ring = np.linspace(0, 2 * np.pi, 7)[:-1]
        keep_out = np.vstack([person, person + 0.3 * np.c_[np.cos(ring), np.sin(ring)]])
        task = EvidentSafetyTask(x0=[-6.0, 0.0, 0.0, SPEED], goal=[6.0, 0.0], hazard=person, keep_out=keep_out,
                                 radius=0.3, horizon=4.0, steps=steps)
        return task, hypothesis_weights(100, 10), hypothesis_weights(100, 10, keep_out=20)
    raise ValueError(f"figure must be '7.1', '7.2' or '6.1', got {figure!r}")


def hypothesis_set(w0, w1, alpha=LEGIBLE_ALPHA):
    """``{"H0": w0, "H1": w1, "legible": (1 + alpha) w1 - w0}``: the three objectives of each figure."""
    return {"H0": np.asarray(w0, float), "H1": np.asarray(w1, float), "legible": legible_weights(w1, w0, alpha)}


def solve_hypotheses(task, w0, w1, alpha=LEGIBLE_ALPHA, **ilqr_options):
    """iLQR optima of H0 (ignorant), H1 (avoidant) and the legible ``(1 + alpha) J1 - J0``, each from rest.

    Returns ``{"H0": ILQRResult, "H1": ..., "legible": ...}``.
    """
    return {name: solve(task, w, **ilqr_options) for name, w in hypothesis_set(w0, w1, alpha).items()}


def relative_gradient(task, weights, result):
    """``max |dJ/du| / (1 + |J|)`` at a solution: zero at a stationary point (autodiff, independent of iLQR)."""
    value, grad = cost_gradient(task, weights, result.us)
    return float(np.abs(grad).max() / (1 + abs(value)))


def lq_hypothesis_costs(task, w0, w1, alpha=LEGIBLE_ALPHA):
    """Fig. 7.1's objectives as chapter 6's :class:`mutual.motion.legible.problem.QuadraticCost` (x' = u, no keep-out),
    for the exact Riccati solution by :func:`mutual.motion.legible.problem.solve`."""
    if task.x0.shape != (2,) or np.any(np.asarray(w0)[2:] != 0) or np.asarray(w1)[3] != 0:
        raise ValueError("lq_hypothesis_costs needs x' = u, H0 without hazard and no keep-out weight")
    if np.any(np.asarray(w1)[:2] != np.asarray(w0)[:2]):
        raise ValueError("w1 must share H0's goal and effort weights (eq. (7.2) adds only the hazard term)")
    dt, h, a3 = task.dt, task.hazard, float(w1[2])
    J0 = reaching_cost(task.goal, dt=dt, terminal_weight=w0[0], effort_weight=w0[1])
    hazard = QuadraticCost(Q=-2 * a3 * dt * np.eye(2), q=2 * a3 * dt * h, R=np.zeros((2, 2)), r=np.zeros(2),
                           QN=np.zeros((2, 2)), qN=np.zeros(2), const=-a3 * dt * task.steps * h @ h)
    J1 = J0 + hazard
    return {"H0": J0, "H1": J1, "legible": legible_cost(J1, J0, alpha)}


def alpha_sweep(task, w0, w1, alphas, **ilqr_options):
    """Distances to ``h`` of the legible optimum for each ``alpha`` (eq. (6.15)), as a DataFrame.

    All alphas are solved at once (:func:`solve_batch`); an alpha whose objective is unbounded
    gets NaN distances and its iLQR message in ``error``.
    """
    alphas = [float(a) for a in alphas]
    if not alphas:
        raise ValueError("alphas must not be empty")
    batch = solve_batch(task, [legible_weights(w1, w0, a) for a in alphas], **ilqr_options)
    rows = []
    for alpha, r, err in zip(alphas, batch.results, batch.errors):
        d = distance_to_point(r.xs, task.hazard, task.dt) if r is not None else {"min": np.nan, "integral": np.nan}
        rows.append({"alpha": alpha, "min distance": d["min"], "integral distance": d["integral"],
                     "iterations": r.iterations if r is not None else -1, "error": err or ""})
    return pd.DataFrame(rows)


def best_of_starts(task, weights, turn_rates=(0.0, 0.5, -0.5, 1.0, -1.0, 2.0, -2.0), second_order=(False, True),
                   rtol=1e-6):
    """The lowest-cost local optimum over iLQR runs from constant controls ``turn_rates`` (all starts of one
    ``second_order`` setting solved at once by :func:`solve_batch`), with a flag for disagreeing runs.

    A check against poor local optima. Returns a :class:`mutual.motion.trajopt.multistart.MultiStart`,
    which unpacks as ``(best ILQRResult, number of runs that converged)``; its ``local_minima``
    is True when converged runs ended at costs that differ by more than ``rtol`` times the
    objective's magnitude (distinct local minima). Raises ValueError when no run converges.
    """
    rates = np.asarray(turn_rates, float).ravel()
    if rates.size == 0 or not np.all(np.isfinite(rates)):
        raise ValueError(f"turn_rates must be a non-empty sequence of finite numbers, got {turn_rates!r}")
    starts = np.broadcast_to(rates[:, None, None], (rates.size, task.steps, task.controls)).copy()
    runs, labels = [], []
    for order in second_order:
        batch = solve_batch(task, weights, starts, second_order=order)
        runs += list(batch.results)
        labels += [f"u0 = {r:g}, second_order = {order}" for r in rates]
    return MultiStart.from_runs(runs, labels, rtol=rtol)
