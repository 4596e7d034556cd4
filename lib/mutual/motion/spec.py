"""A legible-motion problem read from a TOML file (the input of ``mutual motion legible``), and
its solution: legible reaching towards a goal among distractor goals (chapter 6).

The hypotheses are reaching tasks, eq. (6.17) discretised with ``N = steps`` steps of
``dt = horizon / steps``: ``J_i = w_T |p_N - g_i|^2 + w_u dt sum_k |u_k|^2`` with ``g_1`` the
goal (H1) and ``g_0`` each distractor (H0). The legible motion minimises
``(1 + alpha) J_1 - J_0`` (eq. 6.15; Theorem 6.4.2 makes it the minimiser of the likelihood
ratio); with several distractors ``J_0`` is their mean, the equal-weight case of the Lagrangian
of section 6.5 (:func:`mutual.motion.legible.objective.distractor_mixture`). Alternatives: ``eta``
solves the multi-distractor QP of section 6.5, ``min J_1 s.t. J_1 - J_0i <= eta``
(:func:`mutual.motion.legible.qp.multi_distractor_qp`), and an ``[anticipation]`` table replans with
``alpha`` rising linearly over the horizon (eq. 6.16).

``dynamics = "single-integrator"`` (``x' = u`` in the plane, eq. 6.5) is solved exactly by LQR;
``"dubins"`` (the car of eq. 7.5, state ``(x, y, theta)``, constant speed, turn rate ``u``) by
iLQR (:func:`mutual.motion.trajopt.ilqr`) from several constant-turn starts, keeping the best.

The spec (every key; see ``data/README.md``)::

    dynamics = "single-integrator"   # or "dubins"
    start = [0.0, 0.0]               # [x, y]; [x, y, theta] (rad) for "dubins"
    goal = [4.0, 4.0]                # g_1, the goal the motion should make evident
    distractors = [[-4.0, 4.0]]      # g_0: one or more other goals the observer considers
    horizon = 1.0                    # T, seconds
    steps = 100                      # N
    alpha = 1.0                      # > 0, weight on the task (eq. 6.15); or eta = -2.0 (QP)
    terminal_weight = 1.0            # w_T (optional, default 1)
    effort_weight = 1.0              # w_u (optional, default 1)
    speed = 3.0                      # "dubins" only (optional, default 3, eq. 7.5)
    [anticipation]                   # optional, "single-integrator" with alpha only
    alpha_start = 0.25               # alpha(t) rises linearly from alpha_start at t = 0 ...
    alpha_end = 4.0                  # ... to alpha_end at t = T (0 < alpha_start <= alpha_end)
    every = 1                        # replan every this many steps (default 1)
"""

import math
from dataclasses import dataclass

import numpy as np

from ..tomlfile import read_toml

DYNAMICS = ("single-integrator", "dubins")
_KEYS = {"dynamics", "start", "goal", "distractors", "horizon", "steps", "alpha", "eta", "terminal_weight",
         "effort_weight", "speed", "anticipation"}
_ANTICIPATION_KEYS = {"alpha_start", "alpha_end", "every"}
DUBINS_STARTS = (0.0, 0.5, -0.5, 1.0, -1.0)    # constant turn rates (rad/s) iLQR starts from


@dataclass(frozen=True)
class LegibleSpec:
    """A legible reaching problem (module docstring); build it with :func:`legible_spec` or load a TOML file."""
    dynamics: str
    start: tuple
    goal: tuple
    distractors: tuple
    horizon: float
    steps: int
    alpha: float = None
    eta: float = None
    anticipation: tuple = None          # (alpha_start, alpha_end, every)
    terminal_weight: float = 1.0
    effort_weight: float = 1.0
    speed: float = 3.0

    @property
    def dt(self):
        return self.horizon / self.steps

    @property
    def method(self):
        """"lqr", "receding-horizon", "qp" or "ilqr"."""
        if self.dynamics == "dubins":
            return "ilqr"
        if self.eta is not None:
            return "qp"
        return "lqr" if self.anticipation is None else "receding-horizon"


def _fail(source, key, reason):
    raise ValueError(f"{source}: key {key!r}: {reason}")


def _number(d, key, source, default=None, positive=False, prefix=""):
    if key not in d:
        if default is None:
            _fail(source, prefix + key, "missing (required)")
        return float(default)
    v = d[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        _fail(source, prefix + key, f"must be a finite number, got {v!r}")
    if positive and v <= 0:
        _fail(source, prefix + key, f"must be positive, got {v!r}")
    return float(v)


def _point(v, key, source, sizes=(2,)):
    if (not isinstance(v, list) or len(v) not in sizes
            or not all(isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in v)):
        shape = " or ".join(f"{n} numbers" for n in sizes)
        _fail(source, key, f"must be a list of {shape}, got {v!r}")
    return tuple(float(c) for c in v)


def legible_spec(mapping, source="spec"):
    """Check a spec (a dict, as TOML reads it) and return a :class:`LegibleSpec`; ValueError names
    ``source`` and the key."""
    if not isinstance(mapping, dict):
        raise ValueError(f"{source}: must be a table of keys, got {type(mapping).__name__}")
    unknown = sorted(set(mapping) - _KEYS)
    if unknown:
        _fail(source, unknown[0], f"unknown key (known: {', '.join(sorted(_KEYS))})")
    d = mapping
    dynamics = d.get("dynamics", "single-integrator")
    if dynamics not in DYNAMICS:
        _fail(source, "dynamics", f"must be one of {list(DYNAMICS)}, got {dynamics!r}")
    if "start" not in d:
        _fail(source, "start", "missing (required)")
    start = _point(d["start"], "start", source, (3,) if dynamics == "dubins" else (2,))
    if "goal" not in d:
        _fail(source, "goal", "missing (required)")
    goal = _point(d["goal"], "goal", source)
    if "distractors" not in d:
        _fail(source, "distractors", "missing (required)")
    if not isinstance(d["distractors"], list) or not d["distractors"]:
        _fail(source, "distractors", f"must be a non-empty list of [x, y] points, got {d['distractors']!r}")
    distractors = tuple(_point(p, f"distractors[{i}]", source) for i, p in enumerate(d["distractors"]))
    for i, p in enumerate(distractors):
        if p == goal:
            _fail(source, f"distractors[{i}]", f"equals the goal {list(goal)}: nothing to tell apart")
    horizon = _number(d, "horizon", source, positive=True)
    steps = d.get("steps")
    if isinstance(steps, bool) or not isinstance(steps, int) or not 1 <= steps <= 10_000:
        _fail(source, "steps", f"must be an integer in 1..10000, got {steps!r}")
    has_alpha, has_eta = "alpha" in d, "eta" in d
    if has_alpha == has_eta:
        _fail(source, "alpha", "give exactly one of alpha (eq. 6.15) and eta (the QP of section 6.5)")
    alpha = _number(d, "alpha", source, positive=True) if has_alpha else None
    eta = _number(d, "eta", source) if has_eta else None
    if has_eta and dynamics != "single-integrator":
        _fail(source, "eta", "the QP of section 6.5 needs dynamics = \"single-integrator\"")
    anticipation = None
    if "anticipation" in d:
        a = d["anticipation"]
        if not isinstance(a, dict):
            _fail(source, "anticipation", "must be a table ([anticipation])")
        if dynamics != "single-integrator" or not has_alpha:
            _fail(source, "anticipation", "needs dynamics = \"single-integrator\" and alpha")
        unknown = sorted(set(a) - _ANTICIPATION_KEYS)
        if unknown:
            _fail(source, f"anticipation.{unknown[0]}", f"unknown key (known: {', '.join(sorted(_ANTICIPATION_KEYS))})")
        lo = _number(a, "alpha_start", source, positive=True, prefix="anticipation.")
        hi = _number(a, "alpha_end", source, positive=True, prefix="anticipation.")
        if hi < lo:
            _fail(source, "anticipation.alpha_end", f"must be >= alpha_start = {lo:g}, got {hi:g}")
        every = a.get("every", 1)
        if isinstance(every, bool) or not isinstance(every, int) or not 1 <= every <= steps:
            _fail(source, "anticipation.every", f"must be an integer in 1..steps ({steps}), got {every!r}")
        anticipation = (lo, hi, every)
    if dynamics != "dubins" and "speed" in d:
        _fail(source, "speed", "only for dynamics = \"dubins\"")
    return LegibleSpec(dynamics, start, goal, distractors, horizon, steps, alpha, eta, anticipation,
                       _number(d, "terminal_weight", source, 1.0, positive=True),
                       _number(d, "effort_weight", source, 1.0, positive=True),
                       _number(d, "speed", source, 3.0, positive=True))


def load_legible_spec(path):
    """Read a legibility spec TOML file (module docstring) and check it; errors name the file and key."""
    return legible_spec(read_toml(path), str(path))


# ---- solving ---------------------------------------------------------------------------------------

def _costs(spec):
    from .legible.problem import reaching_cost
    J1 = reaching_cost(spec.goal, spec.dt, spec.terminal_weight, spec.effort_weight)
    J0s = [reaching_cost(g, spec.dt, spec.terminal_weight, spec.effort_weight) for g in spec.distractors]
    return J1, J0s


def solve_legible(spec):
    """The legible and the predictable (H1-optimal) motion of ``spec``.

    Returns a dict: ``legible`` and ``predictable`` as ``(xs (N+1, n), us (N, m))``, ``method``,
    ``evidence`` -- per distractor and trajectory, ``log Lambda`` (eq. 6.7, exact for the
    single integrator; negative values favour the goal) or, for the Dubins car, ``J_1 - J_0``
    (equal to ``log Lambda`` up to a constant) -- and ``alphas`` (the weight in force at each
    step) or ``duals`` (the QP's multipliers) where they apply.
    """
    if not isinstance(spec, LegibleSpec):
        raise ValueError("spec must be a LegibleSpec (use legible_spec or load_legible_spec)")
    if spec.dynamics == "dubins":
        return _solve_dubins(spec)
    from . import legible as leg
    from .observer import log_likelihood_ratio
    from .legible.qp import multi_distractor_qp
    dyn = leg.single_integrator(2, spec.dt)
    x0, N = np.array(spec.start), spec.steps
    J1, J0s = _costs(spec)
    out = {"method": spec.method}
    if spec.method == "qp":
        xs, us, duals = multi_distractor_qp(dyn, J1, J0s, x0, N, spec.eta)
        out["duals"] = duals
    elif spec.method == "receding-horizon":
        lo, hi, every = spec.anticipation
        xs, us, alphas = leg.receding_horizon(dyn, J1, leg.distractor_mixture(J0s), x0, N,
                                              leg.linear_alpha_schedule(lo, hi), every)
        out["alphas"] = alphas
    else:
        sol = leg.legible_trajectory(dyn, J1, J0s, x0, N, spec.alpha)     # J0: the distractors' mean
        xs, us = sol.xs, sol.us
        out["alphas"] = np.full(N, spec.alpha)
    plain = leg.solve(dyn, J1, x0, N)
    out["legible"], out["predictable"] = (xs, us), (plain.xs, plain.us)
    out["evidence"] = {name: [log_likelihood_ratio(dyn, J0, J1, x0, u) for J0 in J0s]
                       for name, (_, u) in (("legible", out["legible"]), ("predictable", out["predictable"]))}
    out["evidence_kind"] = "log Lambda"
    return out


def _dubins_step(x, u, params):
    from .evident.vehicles import dubins_step
    return dubins_step(x, u, params["dt"], params["speed"])


def _dubins_running(x, u, params):
    import jax.numpy as jnp
    return params["dt"] * params["effort"] * jnp.sum(u ** 2)


def _dubins_terminal(x, params):
    """``w1 |p_N - g_1|^2 - sum_i w0 |p_N - g_0i|^2`` on the planar position ``p_N``."""
    import jax.numpy as jnp
    p = x[:2]
    return (params["w1"] * jnp.sum((p - params["goal"]) ** 2)
            - params["w0"] * jnp.sum((p[None, :] - params["distractors"]) ** 2))


def _dubins_params(spec, w1, w0, effort):
    return {"dt": np.float64(spec.dt), "speed": np.float64(spec.speed), "w1": np.float64(w1), "w0": np.float64(w0),
            "effort": np.float64(effort), "goal": np.array(spec.goal), "distractors": np.array(spec.distractors)}


def _best_ilqr(spec, params):
    from .trajopt import ILQRError, ilqr
    found, errors = [], []
    for rate in DUBINS_STARTS:
        try:
            found.append(ilqr(_dubins_step, _dubins_running, _dubins_terminal, np.array(spec.start),
                              np.full((spec.steps, 1), rate), params))
        except ILQRError as err:
            errors.append(str(err))
    if not found:
        raise RuntimeError(f"iLQR found no local minimum from any of the starts {DUBINS_STARTS}: {errors[0]}")
    return min(found, key=lambda r: r.cost)


def _solve_dubins(spec):
    wT, wu, K, a = spec.terminal_weight, spec.effort_weight, len(spec.distractors), spec.alpha
    # (1 + alpha) J1 - mean J0: goal weight (1 + alpha) wT, each distractor -wT / K, effort alpha wu
    legible = _best_ilqr(spec, _dubins_params(spec, (1 + a) * wT, wT / K, a * wu))
    plain = _best_ilqr(spec, _dubins_params(spec, wT, 0.0, wu))

    def difference(xs, us):         # J1 - J0_i per distractor (effort cancels)
        p = xs[-1, :2]
        return [float(wT * (np.sum((p - spec.goal) ** 2) - np.sum((p - g) ** 2))) for g in np.array(spec.distractors)]

    return {"method": "ilqr", "legible": (legible.xs, legible.us), "predictable": (plain.xs, plain.us),
            "alphas": np.full(spec.steps, a), "evidence_kind": "J1 - J0",
            "evidence": {"legible": difference(legible.xs, legible.us), "predictable": difference(plain.xs, plain.us)}}
