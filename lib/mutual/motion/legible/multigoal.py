"""Figure 6.3: five reach targets, each evidenced against the other four by the receding-horizon QP of
section 6.5 (``min J1 s.t. J1 - J0_i <= eta_i(t)`` for every distractor ``i``, :mod:`.qp`), and the measures
of its caption (line 1268): the far ends "exaggerate motion out in their respective direction", the interior
goals "have their exaggeration hemmed in, instead anticipating via a sharp juke early and then straight
shooting to the goal after alignment" (:func:`mutual.motion.legible.path_measures.juke`).

Set-up: goals at ``(x_i, height)``, a start ``(start_x, 0)``, x' = u and eq. (6.17) with unit weights over
``horizon``, replanned every ``every`` steps. Under eq. (6.17) ``J1 - J0_i = |x_N - g_1|^2 - |x_N - g_i|^2``
depends only on the end point and is affine in it: ``J1 - J0_i <= eta_i`` keeps the end point on ``g_1``'s
side of the line perpendicular to ``g_i - g_1`` at offset ``o_i = (eta_i + d_i^2) / (2 d_i)`` from ``g_1``
(``d_i = |g_i - g_1|``). With the goals in a row every such line is vertical, so any per-pair bounds confine
the end point to a slab set by the strictest bound on each side: :func:`side_bounds` writes the per-pair
``eta_i`` of a slab given by its two side offsets, in units of the goal spacing (``omega``).
"""

from functools import lru_cache

import numpy as np
import pandas as pd

from ..chain import lq_chains
from ..observer import posterior_from_chains
from .path_measures import juke, outward_excursion
from .problem import reaching_cost, single_integrator, solve
from .qp import receding_horizon_qp

GOAL_XS = (-4.0, -2.0, 0.0, 2.0, 4.0)
ANTICIPATION_AT = 0.25      # the observer's belief is compared a quarter of the way through the motion
BINDS = 0.01                # a bound "binds" when it moves a replan's end point by 1% of the goal's distance


def row_goals(goal_xs=GOAL_XS, height=4.0):
    """The goals ``(x_i, height)`` as a (G, 2) array."""
    return np.array([[x, height] for x in goal_xs], dtype=float)


def side_bounds(goals, j, omega_left, omega_right):
    """Per-pair bounds ``eta_i`` (one per distractor ``i != j``, in order) that put every line of a side at
    that side's offset ``o = omega * spacing`` from ``g_j`` towards the distractors: ``eta_i = d_i (2 o - d_i)``.
    ``spacing`` is the distance to the nearest goal; a side without distractors needs no offset (None)."""
    goals = np.asarray(goals, float)
    spacing = np.min(np.linalg.norm(np.delete(goals, j, 0) - goals[j], axis=1))
    etas = []
    for i, g in enumerate(goals):
        if i == j:
            continue
        omega = omega_left if g[0] < goals[j, 0] else omega_right
        if omega is None or not np.isfinite(omega):
            raise ValueError(f"goal {j} has a distractor on the {'left' if g[0] < goals[j, 0] else 'right'}: "
                             "that side needs a finite offset omega")
        d = np.linalg.norm(g - goals[j])
        etas.append(d * (2 * omega * spacing - d))
    return np.array(etas)


def released(etas0, release):
    """``eta(s) = etas0 max(0, 1 - s / release)``: the bounds loosen linearly to 0 (the pairwise bisectors) at
    ``s = release`` (a fraction of the horizon) and stay there."""
    etas0 = np.asarray(etas0, float)
    if not (np.isfinite(release) and 0 < release <= 1):
        raise ValueError(f"release must be a fraction of the horizon in (0, 1], got {release!r}")
    return lambda s: etas0 * max(0.0, 1.0 - s / release)


def goal_path(goals, j, x0, etas0, release, horizon=20.0, N=100, every=10, solver="active-set"):
    """Goal ``j``'s anticipative path against the other goals (per-pair bounds ``etas0`` released at
    ``release``) and its replans (:func:`mutual.motion.legible.qp.receding_horizon_qp`): ``(xs, us, replans)``."""
    dt = horizon / N
    dyn = single_integrator(2, dt)
    costs = [reaching_cost(g, dt) for g in goals]
    others = [c for i, c in enumerate(costs) if i != j]
    return receding_horizon_qp(dyn, costs[j], others, np.asarray(x0, float), N, released(etas0, release),
                               every=every, solver=solver, record=True)


def _binding(replans, goal, x0):
    """Largest move of a replan's end point by the bounds (relative to the goal's distance from the start) and
    the number of replans with a positive multiplier."""
    scale = np.linalg.norm(np.asarray(goal) - np.asarray(x0))
    shift = max(np.linalg.norm(r["end"] - r["end_free"]) for r in replans) / scale
    return float(shift), int(sum(np.any(r["duals"] > 1e-9) for r in replans))


@lru_cache(maxsize=64)
def _observer(goals, x0, horizon, N):
    """The eq. (6.8) observer's Gaussians over the goals and each goal's plain optimum (cached: a scan asks
    for the same ones many times). ``goals`` and ``x0`` as tuples."""
    dt = horizon / N
    dyn, costs = single_integrator(2, dt), [reaching_cost(np.array(g), dt) for g in goals]
    return lq_chains(dyn, costs, np.array(x0), N), [solve(dyn, c, np.array(x0), N) for c in costs]


def _key(goals, x0):
    return tuple(map(tuple, np.asarray(goals, float).tolist())), tuple(np.asarray(x0, float).tolist())


def belief_at(goals, j, x0, us, horizon, at=ANTICIPATION_AT):
    """``P(goal j | u_{0:t})`` of the eq. (6.8) observer over the goals (uniform prior, exact prefix marginals)
    at ``t = at * horizon``."""
    chains, _ = _observer(*_key(goals, x0), float(horizon), len(us))
    return float(posterior_from_chains(chains, np.asarray(us, float))[int(round(at * len(us))), j])


@lru_cache(maxsize=256)
def _plain_belief(goals, x0, j, horizon, N):
    return belief_at(goals, j, x0, _observer(goals, x0, horizon, N)[1][j].us, horizon)


def goal_measures(goals, j, x0, xs, us, replans, horizon):
    """One goal's path against the caption: outward excursion (away from the row's centre), the juke measures,
    whether it anticipates (the observer believes goal ``j`` more at ``t = T/4`` than watching the plain
    optimum) and how much the bounds bind."""
    goals, x0 = np.asarray(goals, float), np.asarray(x0, float)
    side = np.sign(goals[j, 0] - goals[:, 0].mean()) or 1.0
    belief, belief_plain = belief_at(goals, j, x0, us, horizon), _plain_belief(*_key(goals, x0), j, float(horizon), len(us))
    shift, positive = _binding(replans, goals[j], x0)
    shape = juke(xs, goals[j])
    return {"outward excursion": outward_excursion(xs, goals[j], side), **shape,
            "P(goal | u to T/4)": belief, "P(goal | u to T/4), plain": belief_plain,
            "anticipates": bool(belief > belief_plain), "juke and anticipates": bool(shape["juke"] and belief > belief_plain),
            "end-point shift": shift, "replans with a positive multiplier": positive, "binds": bool(shift >= BINDS)}


def role(j, n_goals):
    """``"far end"``, ``"centre"`` or ``"interior"`` for goal ``j`` of a row of ``n_goals``."""
    return "far end" if j in (0, n_goals - 1) else "centre" if 2 * j == n_goals - 1 else "interior"


def figure_63_paths(goals, x0, omegas, release, horizon=20.0, N=100, every=10):
    """Every goal's anticipative path with its own side offsets ``omegas[j] = (omega_left, omega_right)``
    (None for a side without distractors) and its plain optimum. Returns ``(paths, plain, measures)``, the
    last a DataFrame with one row per goal (:func:`goal_measures`)."""
    goals, x0 = np.asarray(goals, float), np.asarray(x0, float)
    dyn = single_integrator(2, horizon / N)
    paths, plain, rows = [], [], []
    for j, (wl, wr) in enumerate(omegas):
        xs, us, replans = goal_path(goals, j, x0, side_bounds(goals, j, wl, wr), release, horizon, N, every)
        paths.append(xs)
        plain.append(solve(dyn, reaching_cost(goals[j], horizon / N), x0, N).xs)
        rows.append({"goal": f"Lambda_{j + 1}", "goal x": goals[j, 0], "role": role(j, len(goals)),
                     "omega left": np.nan if wl is None else wl, "omega right": np.nan if wr is None else wr,
                     **goal_measures(goals, j, x0, xs, us, replans, horizon)})
    return paths, plain, pd.DataFrame(rows)


def figure_63_verdicts(measures, exaggeration=0.1):
    """The caption's three statements on one figure's measures: ``exterior`` (both far ends stray outwards by
    at least ``exaggeration`` of their segment), ``interior`` (the off-centre interior goals juke and
    anticipate, and stray outwards less than either far end: "hemmed in"), ``centre`` (the centre goal jukes
    and anticipates)."""
    ext = measures[measures["role"] == "far end"]
    inner = measures[measures["role"] == "interior"]
    centre = measures[measures["role"] == "centre"]
    return {"exterior": bool((ext["outward excursion"] >= exaggeration).all()),
            "interior": bool(inner["juke and anticipates"].all()
                             and inner["outward excursion"].max() < ext["outward excursion"].min()),
            "centre": bool(centre["juke and anticipates"].all())}


def goal_cells(n_goals, far_omegas, pair_omegas):
    """Every goal's side offsets over the scan: ``[(j, omega_left, omega_right)]``. The far ends take each of
    ``far_omegas`` on their inner side; the other goals every pair of ``pair_omegas`` with
    ``omega_left + omega_right >= 0`` (else no end point meets both sides)."""
    cells = []
    for j in range(n_goals):
        if j == 0:
            cells += [(j, None, w) for w in far_omegas]
        elif j == n_goals - 1:
            cells += [(j, w, None) for w in far_omegas]
        else:
            cells += [(j, a, b) for a in pair_omegas for b in pair_omegas if a + b >= -1e-12]
    return cells


def figure_63_scan(heights, start_xs, releases, cells, horizon=20.0, N=100, every=10, goal_xs=GOAL_XS):
    """One row per goal and cell of the scan (height x start x release x the goals' side offsets ``cells``,
    :func:`goal_cells`) with :func:`goal_measures` and ``exaggerates`` (outward excursion >= 10%)."""
    rows = []
    for height in heights:
        goals = row_goals(goal_xs, height)
        for start_x in start_xs:
            x0 = np.array([start_x, 0.0])
            for release in releases:
                for j, wl, wr in cells:
                    xs, us, replans = goal_path(goals, j, x0, side_bounds(goals, j, wl, wr), release, horizon, N, every)
                    m = goal_measures(goals, j, x0, xs, us, replans, horizon)
                    rows.append({"goal": f"Lambda_{j + 1}", "role": role(j, len(goals)), "height": height,
                                 "start x": start_x, "release": release,
                                 "omega left": np.nan if wl is None else wl, "omega right": np.nan if wr is None else wr,
                                 **m, "exaggerates": bool(m["outward excursion"] >= 0.1)})
    return pd.DataFrame(rows)


PASSES = {"far end": "exaggerates", "interior": "juke and anticipates", "centre": "juke and anticipates"}


def best_cells(scan, fallback, height=4.0, start_x=0.0, releases=(0.5, 0.25, 1.0)):
    """The figure closest to the caption among a scan's binding cells at ``height`` from ``start_x``: the
    release under which the most goals have a passing cell (ties: the earlier in ``releases``), and for each
    goal its passing cell with the loosest bounds (largest smaller offset, then the most symmetric), or its
    ``fallback`` offsets when none passes. Returns ``(release, [(omega_left, omega_right)] per goal)``."""
    here = scan[(scan["height"] == height) & (scan["start x"] == start_x) & scan["binds"]]
    goals = sorted(set(scan["goal"]), key=lambda g: int(g.split("_")[1]))

    def passing(release, goal):
        rows = here[(here["release"] == release) & (here["goal"] == goal)]
        return rows[rows[PASSES[rows["role"].iloc[0]]]] if len(rows) else rows
    release = max(releases, key=lambda r: (sum(len(passing(r, g)) > 0 for g in goals), -releases.index(r)))
    omegas = []
    for goal, back in zip(goals, fallback):
        rows = passing(release, goal)
        if not len(rows):
            omegas.append(back)
            continue
        w = rows[["omega left", "omega right"]].to_numpy()
        low, spread = np.nanmin(w, axis=1), np.nan_to_num(np.abs(w[:, 0] - w[:, 1]))
        best = rows.iloc[np.lexsort((spread, -low))[0]]
        omegas.append(tuple(None if np.isnan(best[c]) else float(best[c]) for c in ("omega left", "omega right")))
    return release, omegas


def arc_goals(radius=4 * np.sqrt(2), bearings=(45.0, 67.5, 90.0, 112.5, 135.0)):
    """Goals on an arc around the origin (bearings in degrees): equally far from the start, so their partition
    functions are equal and ``J1 - J0_i`` is the observer's log likelihood ratio."""
    b = np.radians(np.asarray(bearings, float))
    return radius * np.c_[np.cos(b), np.sin(b)]


def uniform_bound_paths(goals, x0, eta0, horizon=20.0, N=100, every=10):
    """The first design: every pair of every goal bounded by the same ``eta0``, loosening linearly to 0 over
    the whole horizon. Returns ``(paths, measures)`` like :func:`figure_63_paths`."""
    goals, x0 = np.asarray(goals, float), np.asarray(x0, float)
    if not (np.isfinite(eta0) and eta0 < 0):
        raise ValueError(f"eta0 must be a negative finite number (a strict bound that loosens to 0), got {eta0!r}")
    paths, rows = [], []
    for j in range(len(goals)):
        xs, us, replans = goal_path(goals, j, x0, np.full(len(goals) - 1, eta0), 1.0, horizon, N, every)
        paths.append(xs)
        rows.append({"goal": f"Lambda_{j + 1}", "goal x": goals[j, 0], "role": role(j, len(goals)),
                     **goal_measures(goals, j, x0, xs, us, replans, horizon)})
    return paths, pd.DataFrame(rows)
