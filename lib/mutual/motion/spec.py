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
iLQR from several constant-turn starts, keeping the best (:mod:`mutual.motion.spec_dubins`).

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

from .. import budget
from ..inputs import Keys, angle_unit_warning, read_toml, shown, warn

DYNAMICS = ("single-integrator", "dubins")
_KEYS = {"dynamics", "start", "goal", "distractors", "horizon", "steps", "alpha", "eta", "terminal_weight",
         "effort_weight", "speed", "anticipation"}
_ANTICIPATION_KEYS = {"alpha_start", "alpha_end", "every"}
MAX_STEPS = 10_000
BYTES_PER_STEP = 400            # per step and hypothesis: motions, gains, observer factors (measured 190-360 B)
# Every magnitude of a spec (a coordinate, a weight, dt, alpha, |eta|, speed) lies within [1e-50, 1e50], so that the
# products the solvers form (squared distances times weights over time steps, the legible weights, ...) stay well
# inside float64's range (~1e308); alpha >= 1e-6, since (1 + alpha) J1 - J0 keeps only alpha's share of the
# quadratic cost and float64 rounds 1 + alpha to a relative 1e-16 / alpha; a distractor must lie farther than
# 1e-9 of the positions' scale from the goal, or float64 cannot tell the two hypotheses apart.
MAGNITUDE = 1e50
ALPHA_MIN = 1e-6
SEPARATION_RTOL = 1e-9
HEADING_MAX = 1e6               # |theta| (rad): beyond it float64 resolves an angle to worse than 1e-10 rad
REACH_RATIO = 1e9               # the Dubins car's reach and the goals' distance: within this factor of each other


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


def _within(keys, key, value, low, high, why):
    if not low <= abs(value) <= high:
        keys.fail(key, f"must lie within [{low:g}, {high:g}] in magnitude, got {value:.6g}: {why}")


def _check_reach(keys, spec, goals):
    """The car's reach ``speed * horizon`` and the goals' distance from the start within :data:`REACH_RATIO` of
    each other: beyond, a turn changes the costs by less than iLQR's stopping test resolves (relative 1e-12)."""
    reach = spec.speed * spec.horizon
    key, far = max(((k, math.dist(p, spec.start[:2])) for k, p in goals), key=lambda kp: kp[1])
    if far > REACH_RATIO * reach or reach > REACH_RATIO * far:
        blame = key if far > reach else "speed"
        keys.fail(blame, f"the car's reach speed x horizon = {reach:.3g} and the goals' distance {far:.3g} from "
              f"the start differ by more than {REACH_RATIO:g} times: a turn would change the costs by less than "
              "iLQR's stopping test resolves (relative 1e-12 of the cost)")


def _check_magnitudes(keys, spec):
    """Refuse a spec whose numbers would take the solvers beyond float64 (see :data:`MAGNITUDE`), naming the key."""
    points = [("start", spec.start[:2]), ("goal", spec.goal)] + [(f"distractors[{i}]", p)
                                                                 for i, p in enumerate(spec.distractors)]
    far = "squared distances times weights would leave float64's range; express the positions in larger units"
    for key, p in points:
        _within(keys, key, max(abs(c) for c in p), 0.0, MAGNITUDE, far)
    if spec.dynamics == "dubins":
        _within(keys, "start", spec.start[2], 0.0, HEADING_MAX, "float64 cannot resolve so large a heading (rad)")
    scale = max(max(abs(c) for c in p) for _, p in points)
    for i, g in enumerate(spec.distractors):
        gap = math.dist(g, spec.goal)
        if gap <= SEPARATION_RTOL * scale:
            keys.fail(f"distractors[{i}]", f"lies {gap:.3g} from the goal, within {SEPARATION_RTOL:g} of the "
                  f"positions' scale {scale:.3g} (the largest coordinate of start, goal and distractors): at that "
                  "scale float64 cannot tell the two hypotheses apart")
    small = "far from 1 in float64 terms: the cost's products would underflow or overflow; rescale the units"
    for key in ("terminal_weight", "effort_weight") + (("speed",) if spec.dynamics == "dubins" else ()):
        _within(keys, key, getattr(spec, key), 1 / MAGNITUDE, MAGNITUDE, small)
    _within(keys, "horizon", spec.dt, 1 / MAGNITUDE, MAGNITUDE,
            f"the time step horizon / steps = {spec.dt:.3g} s is {small}")
    rounding = f"below {ALPHA_MIN:g}, float64's rounding of (1 + alpha) J1 - J0 (relative 1e-16 / alpha) shows"
    alphas = [("alpha", spec.alpha)] if spec.alpha is not None else []
    if spec.anticipation is not None:
        alphas += [("anticipation.alpha_start", spec.anticipation[0]), ("anticipation.alpha_end", spec.anticipation[1])]
    for key, a in alphas:
        _within(keys, key, a, ALPHA_MIN, MAGNITUDE, rounding if a < ALPHA_MIN else small)
    if spec.eta is not None:
        _within(keys, "eta", spec.eta, 0.0, MAGNITUDE, "a bound on J1 - J0 (nats) beyond float64's reach")
    if spec.dynamics == "dubins":
        _check_reach(keys, spec, points[1:])


def legible_spec(mapping, source="spec"):
    """Check a spec (a dict, as TOML reads it) and return a :class:`LegibleSpec`; ValueError names
    ``source`` and the key."""
    keys = Keys(mapping, source).known(sorted(_KEYS), ("start", "goal", "distractors"))
    dynamics = keys.choice("dynamics", DYNAMICS, default="single-integrator")
    start = tuple(keys.numbers("start", 3 if dynamics == "dubins" else 2))
    goal = tuple(keys.numbers("goal", 2))
    distractors = keys.get("distractors")
    if not isinstance(distractors, list) or not distractors:
        keys.fail("distractors", f"must be a non-empty list of [x, y] points, got {shown(distractors)}")
    distractors = tuple(tuple(keys.numbers(f"distractors[{i}]", 2, value=p)) for i, p in enumerate(distractors))
    for i, p in enumerate(distractors):
        if p == goal:
            keys.fail(f"distractors[{i}]", f"equals the goal {list(goal)}: nothing to tell apart")
    horizon = keys.number("horizon", low=0, low_open=True)
    steps = _steps(keys, len(distractors))
    has_alpha, has_eta = "alpha" in keys, "eta" in keys
    if has_alpha == has_eta:
        keys.fail("alpha", "give exactly one of alpha (eq. 6.15) and eta (the QP of section 6.5)")
    alpha = keys.number("alpha", low=0, low_open=True) if has_alpha else None
    eta = keys.number("eta") if has_eta else None
    if has_eta and dynamics != "single-integrator":
        keys.fail("eta", "the QP of section 6.5 needs dynamics = \"single-integrator\"")
    anticipation = _anticipation(keys, dynamics, has_alpha, steps) if "anticipation" in keys else None
    if dynamics != "dubins" and "speed" in keys:
        keys.fail("speed", "only for dynamics = \"dubins\"")
    weights = [keys.number(k, low=0, low_open=True, default=d) for k, d in
               (("terminal_weight", 1.0), ("effort_weight", 1.0), ("speed", 3.0))]
    spec = LegibleSpec(dynamics, start, goal, distractors, horizon, steps, alpha, eta, anticipation,
                       *(float(w) for w in weights))
    _check_magnitudes(keys, spec)
    if dynamics == "dubins":
        unit = angle_unit_warning([start[2]], f"{source}: key 'start', the heading theta (radians)")
        if unit:
            warn(unit)
    return spec


def _steps(keys, n_distractors):
    """``steps`` in 1..MAX_STEPS; beyond, the memory and time it would take."""
    steps = keys.get("steps")
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        keys.fail("steps", f"must be an integer in 1..{MAX_STEPS}, got {shown(steps)}")
    if steps > MAX_STEPS:
        many = float(min(steps, 10 ** 300))
        keys.fail("steps", f"must be an integer in 1..{MAX_STEPS}, got {shown(steps)}: its motions, Riccati gains and "
                  f"observer factors would need about {many * BYTES_PER_STEP * (2 + n_distractors) / 2 ** 30:.3g} GiB, "
                  f"and a solve would take {many / MAX_STEPS:.3g} times the few seconds {MAX_STEPS} steps take")
    return steps


def _anticipation(keys, dynamics, has_alpha, steps):
    """``(alpha_start, alpha_end, every)`` of the ``[anticipation]`` table."""
    if not isinstance(keys.get("anticipation"), dict):
        keys.fail("anticipation", "must be a table ([anticipation])")
    if dynamics != "single-integrator" or not has_alpha:
        keys.fail("anticipation", "needs dynamics = \"single-integrator\" and alpha")
    a = keys.table("anticipation", sorted(_ANTICIPATION_KEYS))
    lo = a.number("alpha_start", low=0, low_open=True)
    hi = a.number("alpha_end", low=0, low_open=True)
    if hi < lo:
        a.fail("alpha_end", f"must be >= alpha_start = {lo:g}, got {hi:g}")
    return lo, hi, a.number("every", 1, steps, integer=True, default=1)


def load_legible_spec(path):
    """Read a legibility spec TOML file (module docstring) and check it; errors name the file and key."""
    return legible_spec(read_toml(path), str(path))


# ---- solving ---------------------------------------------------------------------------------------

def _costs(spec):
    from .legible.problem import reaching_cost
    J1 = reaching_cost(spec.goal, spec.dt, spec.terminal_weight, spec.effort_weight)
    J0s = [reaching_cost(g, spec.dt, spec.terminal_weight, spec.effort_weight) for g in spec.distractors]
    return J1, J0s


def solve_legible(spec, allow_large=None):
    """The legible and the predictable (H1-optimal) motion of ``spec``.

    Returns a dict: ``legible`` and ``predictable`` as ``(xs (N+1, n), us (N, m))``, ``method``,
    ``evidence`` -- per distractor and trajectory, ``log Lambda`` (eq. 6.7, exact for the
    single integrator; negative values favour the goal) or, for the Dubins car, ``J_1 - J_0``
    (equal to ``log Lambda`` up to a constant) -- and ``alphas`` (the weight in force at each
    step) or ``duals`` (the QP's multipliers) where they apply. A ValueError names the key when the
    spec asks for what cannot be solved or represented; no output is ever NaN or infinite. ``allow_large``:
    as :func:`mutual.budget.check` (the work grows with the steps times the goals).
    """
    if not isinstance(spec, LegibleSpec):
        raise ValueError("spec must be a LegibleSpec (use legible_spec or load_legible_spec)")
    budget.check(budget.legible(spec.steps, 1 + len(spec.distractors), spec.dynamics), allow_large)
    if spec.dynamics == "dubins":
        from .spec_dubins import solve_dubins
        out = solve_dubins(spec)
    else:
        out = _solve_single_integrator(spec)
    _check_finite(out)
    return out


def _solve_single_integrator(spec):
    """LQR, receding horizon or the QP, from one banded factorisation of the observer's Gaussians (eq. 6.8)
    for the goal and each distractor (:mod:`mutual.motion.chain`): the goal's mode is the predictable
    motion, and since the hypotheses share their quadratic part (eq. (6.17) with common weights), the
    goal's gains with the mean of the distractors' feedforwards give every legible and anticipative
    replan (:func:`mutual.motion.legible.objective.shared_quadratic_gains`)."""
    from .chain import log_ratio_prefix, lq_chains, rollout
    from .legible.objective import linear_alpha_schedule, mixed_feedforward, policy_rollout, scheduled_alphas
    from .legible.problem import single_integrator
    dyn = single_integrator(2, spec.dt)
    x0, N = np.array(spec.start), spec.steps
    J1, J0s = _costs(spec)
    goal, *others = lq_chains(dyn, [J1] + J0s, x0, N)
    predictable = (rollout(goal.A, goal.B, goal.c, x0, goal.mean), goal.mean)
    out = {"method": spec.method}
    if spec.method == "qp":
        xs, us, out["duals"] = _qp(spec, dyn, J1, J0s, x0, predictable)
    else:
        alphas = np.full(N, spec.alpha) if spec.anticipation is None else \
            scheduled_alphas(linear_alpha_schedule(*spec.anticipation[:2]), N, spec.anticipation[2])
        distractors = np.mean([other.k for other in others], axis=0)          # J0: the distractors' mean
        xs, us = policy_rollout(dyn, x0, goal.K, mixed_feedforward(goal.k, distractors, 1.0 + alphas, 1.0))
        out["alphas"] = alphas
    out["legible"], out["predictable"] = (xs, us), predictable
    out["evidence"] = {name: [float(log_ratio_prefix(u, other, goal, name=f"the {name} motion")[-1])
                              for other in others]
                       for name, (_, u) in (("legible", out["legible"]), ("predictable", predictable))}
    out["evidence_kind"] = "log Lambda"
    return out


def evidence_gaps(spec, p):
    """``J1 - J0_i`` for each distractor at the end point ``p`` (eq. (6.17): the effort cancels), as
    ``2 w_T (g0i - g1).(p - (g0i + g1) / 2)``: no difference of two large squares."""
    g1, p = np.array(spec.goal), np.asarray(p, float)[:2]
    return np.array([2 * spec.terminal_weight * (g0 - g1) @ (p - (g0 + g1) / 2) for g0 in np.array(spec.distractors)])


def eta_bound(spec):
    """The smallest ``eta`` any motion can meet: ``min_p max_i J1 - J0_i`` over the end point ``p`` (every
    ``p`` is reachable, and with ``q = p - g1``, ``d_i = g0i - g1`` each ``J1 - J0_i = w_T (2 d_i.q - |d_i|^2)``
    is affine). A linear program; ``-inf`` when no bound holds (the distractors do not surround the goal)."""
    from scipy.optimize import linprog
    d = np.array(spec.distractors) - np.array(spec.goal)
    w = spec.terminal_weight
    lp = linprog([0.0, 0.0, 1.0], A_ub=np.hstack([2 * w * d, -np.ones((len(d), 1))]),
                 b_ub=w * np.einsum("ij,ij->i", d, d), bounds=[(None, None)] * 3, method="highs")
    return -np.inf if lp.status == 3 else float(lp.fun)


def _qp(spec, dyn, J1, J0s, x0, predictable):
    """The multi-distractor QP of section 6.5 for ``spec.eta``; a ValueError names ``eta`` when no motion
    meets it, or when the solver cannot."""
    bound = eta_bound(spec)
    if np.isfinite(bound) and not spec.eta > bound + 1e-9 * max(1.0, abs(bound)):
        raise ValueError(f"key 'eta': no motion meets J1 - J0_i <= eta = {spec.eta:g} for every distractor: the "
                         f"smallest bound any end point meets is {bound:.6g}, so eta must exceed it")

    loose = evidence_gaps(spec, predictable[0][-1]).max()
    if loose <= spec.eta:                               # the constraints do not bind: the predictable motion
        return (*predictable, np.zeros(len(J0s)))
    from .legible.qp import multi_distractor_qp          # cvxpy: imported only when the bound binds
    try:
        xs, us, duals = multi_distractor_qp(dyn, J1, J0s, x0, spec.steps, spec.eta)
    except ValueError:
        reach = (loose - spec.eta) / (2 * spec.terminal_weight * min(math.dist(g, spec.goal) for g in spec.distractors))
        raise ValueError(f"key 'eta': the QP solver failed for eta = {spec.eta:g}, though end points meeting it exist "
                         f"(the smallest bound any end point meets is {bound:.6g}): they lie about {reach:.3g} beyond "
                         f"the predictable one, farther than the solver resolves; choose an eta nearer the "
                         f"predictable motion's max J1 - J0_i = {loose:.6g}") from None
    worst = evidence_gaps(spec, xs[-1]).max()
    if not worst <= spec.eta + 1e-6 * max(1.0, abs(spec.eta), abs(bound) if np.isfinite(bound) else 0.0):
        raise ValueError(f"key 'eta': the QP solver returned a motion with J1 - J0 = {worst:.6g} > eta = "
                         f"{spec.eta:g}: eta = {spec.eta:g} is too close to what any motion can meet ({bound:.6g})")
    return xs, us, duals


def _check_finite(out):
    """Refuse a solution with NaN or infinite values (never printed as null), naming the keys that set its scale."""
    parts = {"legible motion": out["legible"], "predictable motion": out["predictable"],
             "evidence": list(out["evidence"].values()), "weights": out.get("alphas", 0.0),
             "multipliers": out.get("duals", 0.0)}
    for what, value in parts.items():
        if not all(np.all(np.isfinite(np.asarray(a, float))) for a in (value if isinstance(value, (tuple, list))
                                                                       else [value])):
            raise ValueError(f"keys 'start', 'goal', 'distractors', 'horizon', 'steps' and the weights: the {what} "
                             "left float64's range (non-finite values); bring the spec's numbers nearer to 1")
