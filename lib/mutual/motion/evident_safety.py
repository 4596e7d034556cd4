"""Evident safety (chapter 7): legible avoidance for the single integrator and the Dubins car.

Every hypothesis cost of chapter 7 is a weighted sum of four features of a
trajectory, discretised with ``N`` steps of ``dt = T / N`` (left Riemann sums,
as :mod:`mutual.motion.legibility` does)::

    J(u; w) = w_goal   |P x_N - g|^2                                  (eqs. 7.1, 7.3)
            + w_effort dt sum_k |u_k|^2                                (eqs. 7.1, 7.3)
            - w_hazard dt sum_k |P x_k - h|^2                          (eqs. 7.2, 7.4)
            + w_keep   dt sum_k sum_s exp(-|P x_k - s|^2 / (2 r^2))    (keep-out states s)

``P`` projects the state onto the plane. The last feature is our extension beyond
the thesis: a smooth potential field [59] over a set of keep-out states (e.g. a
constraint inferred in chapters 2-3 or a keep-out set of chapter 4), so a robot
can evidence that it respects a learned constraint. Because costs are linear in
the weights, the legible objective ``(1 + alpha) J1 - J0`` of eq. (6.15) is the
same feature cost with weights ``(1 + alpha) w1 - w0``
(:func:`mutual.motion.legibility.legible_cost`), so H0, H1 and the legible problem
share one compiled iLQR (:mod:`mutual.motion.ilqr`).

Dynamics: ``x' = u`` in the plane (Fig. 7.1), or the Dubins car of eq. (7.5),
``(x, y, theta)' = (v cos theta, v sin theta, u)`` with ``v = 3``, integrated
exactly for controls held constant over each step (:func:`dubins_step`).
"""

from dataclasses import dataclass, field

import jax.numpy as jnp
import numpy as np
import pandas as pd

from ..style import PALETTE
from .ilqr import ILQRError, ilqr, solve_single_shooting, trajectory_cost, trajectory_cost_grad
from .legibility import legible_cost, QuadraticCost, reaching_cost

SPEED = 3.0  # v of eq. (7.5)
FEATURES = ("goal", "effort", "hazard", "keep_out")


def project(x):
    """``P x`` with ``P = [[1, 0, 0], [0, 1, 0]]`` (section 7.2): the planar position of a state,
    i.e. its first two coordinates (identity for ``x' = u`` in the plane; works on batches)."""
    return x[..., :2]


def dubins_step(x, u, dt, speed=SPEED):
    """Eq. (7.5) integrated exactly over ``dt`` with the turn rate ``u`` (shape (1,)) held constant.

    The car turns by ``u dt`` along an arc whose chord has length ``v dt sinc(u dt / 2)``
    and points at the mean heading ``theta + u dt / 2`` (finite and smooth as u -> 0).
    The same integrator as :func:`mutual.supervision.dubins.dubins_step`, written in JAX.
    """
    turn = u[0] * dt
    chord = speed * dt * jnp.sinc(turn / (2 * jnp.pi))  # jnp.sinc(z) = sin(pi z) / (pi z)
    mid = x[2] + turn / 2
    return jnp.stack([x[0] + chord * jnp.cos(mid), x[1] + chord * jnp.sin(mid), x[2] + turn])


def single_integrator_step(x, u, dt):
    """``x' = u`` (eq. (6.5)) over ``dt``: exact for a control held constant, ``x + dt u``."""
    return x + dt * u


def hazard_term(p, hazard):
    """``|p - h|^2``: the squared distance from ``h`` that eq. (7.4) rewards with weight ``a3``."""
    return jnp.sum((p - hazard) ** 2, axis=-1)


def keep_out_penalty(p, states, radius):
    """Smooth keep-out penalty ``sum_s 1 / (1 + |p - s|^2 / r^2)`` over keep-out states ``s`` (K, 2).

    A potential field [59]: each keep-out state contributes a bump of height 1 and
    width ``radius`` with a long (inverse-square) tail, so raising its weight, as the
    legible objective does, pushes the path visibly farther; no keep-out states give zero.
    """
    d2 = jnp.sum((p[..., None, :] - states) ** 2, axis=-1)
    return jnp.sum(1.0 / (1.0 + d2 / radius ** 2), axis=-1)


def _step(x, u, params):
    """The task's dynamics: the Dubins car for a 3-dimensional state, else ``x' = u``."""
    dt = params["dt"]
    if x.shape[0] == 3:
        return dubins_step(x, u, dt, params["speed"])
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
    """A planar reach task with something to keep away from (section 7.1-7.2).

    ``x0`` (2,) for ``x' = u`` or (3,) ``(x, y, theta)`` for the Dubins car; ``goal`` g and
    ``hazard`` h planar points; ``keep_out`` (K, 2) keep-out states with bump width
    ``radius``; ``horizon`` T (seconds) split into ``steps`` N; ``speed`` v of eq. (7.5).
    """

    x0: np.ndarray
    goal: np.ndarray
    hazard: np.ndarray = field(default_factory=lambda: np.zeros(2))
    keep_out: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    radius: float = 1.0
    horizon: float = 1.0
    steps: int = 100
    speed: float = SPEED

    def __post_init__(self):
        x0 = np.asarray(self.x0, float)
        if x0.shape not in ((2,), (3,)):
            raise ValueError(f"x0 must be a planar position (2,) or a Dubins state (3,), got shape {x0.shape}")
        for name, shape in (("goal", (2,)), ("hazard", (2,))):
            value = np.asarray(getattr(self, name), float)
            if value.shape != shape:
                raise ValueError(f"{name} must be a planar point of shape (2,), got shape {value.shape}")
            object.__setattr__(self, name, value)
        keep_out = np.asarray(self.keep_out, float) if np.size(self.keep_out) else np.zeros((0, 2))
        if keep_out.ndim != 2 or keep_out.shape[1] != 2:
            raise ValueError(f"keep_out must have shape (K, 2), got shape {np.shape(self.keep_out)}")
        arrays = (x0, self.goal, self.hazard, keep_out)
        if not all(np.all(np.isfinite(a)) for a in arrays):
            raise ValueError("x0, goal, hazard and keep_out must be finite")
        for name in ("radius", "horizon", "speed"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"{name} must be a positive finite number, got {getattr(self, name)!r}")
        if not (isinstance(self.steps, (int, np.integer)) and self.steps >= 1):
            raise ValueError(f"steps must be a positive integer, got {self.steps!r}")
        object.__setattr__(self, "x0", x0)
        object.__setattr__(self, "keep_out", keep_out)

    @property
    def dt(self):
        """Step length ``T / N``."""
        return self.horizon / self.steps

    @property
    def controls(self):
        """Number of controls: 2 for ``x' = u``, 1 (the turn rate) for the Dubins car."""
        return 2 if self.x0.shape == (2,) else 1

    def params(self, weights):
        """The traced parameters of the feature cost for weight vector ``weights`` (see FEATURES)."""
        w = np.asarray(weights, float)
        if w.shape != (len(FEATURES),) or not np.all(np.isfinite(w)):
            raise ValueError(f"weights must be {len(FEATURES)} finite numbers {FEATURES}, got {weights!r}")
        # numpy float64 arrays: iLQR converts them under its 64-bit context
        return {"weights": w, "goal": self.goal, "hazard": self.hazard, "keep_out": self.keep_out,
                "radius": np.float64(self.radius), "dt": np.float64(self.dt), "speed": np.float64(self.speed)}

    def zero_controls(self):
        """The initial guess of every solve: no control (straight ahead / stand still)."""
        return np.zeros((self.steps, self.controls))


def hypothesis_weights(goal, effort, hazard=0.0, keep_out=0.0):
    """Weights ``(a1, a2, a3, a4)`` of the feature cost: H0 of eqs. (7.1)/(7.3) has ``hazard = keep_out = 0``."""
    return np.array([goal, effort, hazard, keep_out], dtype=float)


def legible_weights(w1, w0, alpha):
    """Weights of ``(1 + alpha) J1 - J0`` (eq. (6.15)); costs are linear in their weights."""
    return legible_cost(np.asarray(w1, float), np.asarray(w0, float), alpha)


def problem(task, weights):
    """``(dynamics, running_cost, terminal_cost, x0, params)`` for :mod:`mutual.motion.ilqr`'s functions."""
    return _step, _running, _terminal, task.x0, task.params(weights)


def solve(task, weights, us0=None, **ilqr_options):
    """Minimise the feature cost with ``weights`` by iLQR from ``us0`` (default: zero controls)."""
    dyn, run, term, x0, params = problem(task, weights)
    us0 = task.zero_controls() if us0 is None else us0
    return ilqr(dyn, run, term, x0, us0, params, **ilqr_options)


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


def distance_to_point(xs, point, dt):
    """Minimum and integral distance of the planar path ``P xs`` (N+1, n) to ``point``.

    The integral is ``int_0^T |P x(t) - h| dt`` by the trapezoid rule on the step grid.
    Returns ``{"min": ..., "integral": ...}``.
    """
    xs = np.asarray(xs, float)
    if xs.ndim != 2 or xs.shape[1] < 2:
        raise ValueError(f"xs must have shape (N+1, n >= 2), got {xs.shape}")
    d = np.linalg.norm(xs[:, :2] - np.asarray(point, float), axis=1)
    return {"min": float(d.min()), "integral": float(np.trapezoid(d, dx=dt))}


# ---- the scenarios of Figs. 7.1, 7.2 and 6.1 ----------------------------------------------------

LEGIBLE_ALPHA = 0.5  # alpha of eq. (6.15) for every legible path here (the thesis gives none; see notebook)


def figure_scenario(figure, steps=100):
    """``(task, w0, w1)`` for ``"7.1"``, ``"7.2"`` or ``"6.1"``: the task and the weights of H0 and H1.

    Thesis values: Fig. 7.1 g = [2, -2], a1 = 40, a2 = 25, a3 = 1 with x' = u and h at the
    origin; Fig. 7.2 the Dubins car, g = [2, -1], h = [-2, 2], a1 = 800, a2 = 10, a3 = 2.
    Our choices (the thesis is silent): start states, horizons, N = ``steps``, and all of
    Fig. 6.1 (a car passing a person standing just off its straight course, who is
    modelled by seven keep-out states: a centre and a ring of radius 0.3; the task's
    ``hazard`` is the person's position, used only to measure distances, with weight 0).
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
        task = EvidentSafetyTask(x0=[-6.0, 0.0, 0.0], goal=[6.0, 0.0], hazard=person, keep_out=keep_out,
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
    """Fig. 7.1's objectives as chapter 6's :class:`mutual.motion.legibility.QuadraticCost` (x' = u, no keep-out),
    for the exact Riccati solution by :func:`mutual.motion.legibility.solve`."""
    if task.controls != 2 or np.any(np.asarray(w0)[2:] != 0) or np.asarray(w1)[3] != 0:
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
    """Distances to ``h`` of the legible optimum for each ``alpha`` (eq. (6.15)), as a DataFrame."""
    rows = []
    for alpha in alphas:
        r = solve(task, legible_weights(w1, w0, alpha), **ilqr_options)
        d = distance_to_point(r.xs, task.hazard, task.dt)
        rows.append({"alpha": alpha, "min distance": d["min"], "integral distance": d["integral"],
                     "iterations": r.iterations})
    return pd.DataFrame(rows)


def best_of_starts(task, weights, turn_rates=(0.0, 0.5, -0.5, 1.0, -1.0, 2.0, -2.0), second_order=(False, True)):
    """The lowest-cost local optimum over iLQR/DDP runs from constant controls ``turn_rates``.

    A check against poor local optima; runs that raise :class:`ILQRError` are skipped.
    Returns ``(best ILQRResult, number of runs that converged)``.
    """
    found = []
    for rate in turn_rates:
        for order in second_order:
            try:
                found.append(solve(task, weights, np.full((task.steps, task.controls), rate), second_order=order))
            except ILQRError:
                continue
    if not found:
        raise ValueError("no start converged; the task may be unbounded or badly scaled")
    return min(found, key=lambda r: r.cost), len(found)


def distance_table(results, point, dt):
    """Minimum and integral distance to ``point`` for each solved hypothesis, as a DataFrame."""
    rows = [{"hypothesis": name, **{f"{k} distance": v for k, v in distance_to_point(r.xs, point, dt).items()}}
            for name, r in results.items()]
    return pd.DataFrame(rows)


def plot_paths(ax, results, task, point_label="h", title=None):
    """Draw the planar paths of H0 (black), H1 (grey) and legible (green) with start, goal and hazard."""
    style = {"H0": (PALETTE["black"], "H0 (ignorant)"), "H1": ("#8c8c8c", "H1 (avoidant)"),
             "legible": (PALETTE["green"], "legible: min (1+\u03b1) J1 - J0")}
    for name, r in results.items():
        color, label = style.get(name, (None, name))
        ax.plot(r.xs[:, 0], r.xs[:, 1], color=color, label=label)
    ax.plot(*task.x0[:2], "o", color=PALETTE["black"], ms=4)
    ax.plot(*task.goal, "*", color=PALETTE["blue"], ms=10, label="goal g")
    if len(task.keep_out):
        ax.plot(*task.keep_out.T, ".", color=PALETTE["vermillion"], label="keep-out states")
    else:
        ax.plot(*task.hazard, "X", color=PALETTE["vermillion"], ms=8, label=point_label)
    ax.set_aspect("equal")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    if title:
        ax.set_title(title)
    return ax
