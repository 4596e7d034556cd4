"""Chapter 3's numbers together, and where the scan's ranges end (CLAIMS.md rule 8).

The thesis reports from one run: the bottom-middle cell with F = 0.29 (Figure 3.2), the four
task-relevant truths recovered "by the fifth iteration", and F retracting to 0.96 "after the fourth
constraint", an untrue one (Figure 3.3). :func:`distance` measures how far one run is from all of it, in
units of each number's tolerance (the claims' own: 0.05 on F = 0.29, 0.03 on F = 0.96, one round on each
round); :func:`rank_setups` ranks the scan's cells by their mean over seeds, :func:`refinement` puts a finer
grid of reward scales around the best ones, and :func:`best_setup` reports the closest.
:func:`calibrated_settings` is the second search, added after the first had run: at each layout, horizon
and width, the reward scale at which F of the bottom-middle cell in round 1 is 0.29 (:func:`calibrated_scale`).

:func:`saturation_table` measures the demonstrator itself (no inference) at every world of the scan: its
expected number of moves before it reaches the goal, the share of its trajectories that end at the goal,
and its entropy per move. The reward scale's range ends one doubling past where the moves stop changing
(near-deterministic), the horizon's starts where nearly all demonstrations reach the goal.
"""

import numpy as np
import pandas as pd

from .backup import log_partition, state_action_visitation
from .chance import constraint_mask
from .gridworld import GRID_ACTIONS
from .layouts import CHOSEN_LAYOUT
from .mdp import _transpose_times, soft_policy
from .scan import CELL, F_BOTTOM_MIDDLE, F_BOTTOM_MIDDLE_TOL, F_RETRACTS, F_RETRACTS_TOL, RECOVERY_ROUND, \
    RETRACTION_ROUND, ROUNDS, Setting

TERMS = ("F bottom-middle", "F retraction", "retraction round", "recovery round")


def distance_terms(row, rounds=ROUNDS):
    """The four distances of one run from the thesis, each in units of its tolerance: |F(bottom-middle) - 0.29|
    / 0.05, |F of the first untrue choice - 0.96| / 0.03, |its round - 5| and |the round by which the four
    task-relevant truths are chosen - 4|. A number the run did not reach counts as F = 1 (never avoided, or
    no retraction) or round ``rounds`` + 1."""
    F_bm = row["F bottom-middle"] if np.isfinite(row["F bottom-middle"]) else 1.0
    F_ret = row["F first untrue"] if np.isfinite(row["F first untrue"]) else 1.0
    ret = row["first untrue at"] if _given(row["first untrue at"]) else rounds + 1
    rec = row["recovered at"] if _given(row["recovered at"]) else rounds + 1
    return dict(zip(TERMS, (abs(F_bm - F_BOTTOM_MIDDLE) / F_BOTTOM_MIDDLE_TOL, abs(F_ret - F_RETRACTS) / F_RETRACTS_TOL,
                            abs(ret - RETRACTION_ROUND), abs(rec - RECOVERY_ROUND))))


def _given(v):
    return v is not None and not (isinstance(v, float) and np.isnan(v))


def distance(row, rounds=ROUNDS):
    """The sum of :func:`distance_terms`: 0 when a run reproduces all four numbers exactly."""
    return float(sum(distance_terms(row, rounds).values()))


def rank_setups(table):
    """The scan's cells ranked by their mean :func:`distance` over seeds, with each term's mean and the seeds."""
    terms = pd.DataFrame([distance_terms(r) for r in table.to_dict("records")], index=table.index)
    scored = pd.concat([table[CELL + ["seed", "at goal"]], terms], axis=1).assign(distance=terms.sum(axis=1))
    out = scored.groupby(CELL, sort=False).agg(
        distance=("distance", "mean"), best_seed=("distance", "min"), seeds=("seed", "size"),
        at_goal=("at goal", "mean"), **{t: (t, "mean") for t in TERMS}).reset_index()
    return out.rename(columns={"best_seed": "best seed", "at_goal": "at goal"}).sort_values(
        ["distance", "layout"], kind="stable").reset_index(drop=True)


def refinement(ranked, layouts, top=5, factor=2 ** 0.5):
    """Settings around the ``top`` cells of :func:`rank_setups`: each one's reward scale divided and multiplied
    by ``factor`` (half a doubling) and itself, the layout, horizon and width kept (``layouts`` by name)."""
    by_name = {lay.name: lay for lay in layouts}
    out = []
    for r in ranked.head(top).to_dict("records"):
        factor_T = r["horizon"] / r["width"]
        for b in (r["reward scale"] / factor, r["reward scale"], r["reward scale"] * factor):
            s = Setting(float(b), factor_T, int(r["width"]), by_name[r["layout"]])
            if s.horizon != r["horizon"]:
                raise ValueError(f"ranked: horizon {r['horizon']} is no round multiple of width {r['width']}")
            if s not in out:
                out.append(s)
    return out


def best_setup(ranked):
    """The closest set-up of ``ranked`` (:func:`rank_setups`) as a dict: its cell, mean distance, each term's
    mean and the share of demonstrations that reach the goal."""
    return {k: (v.item() if hasattr(v, "item") else v) for k, v in ranked.iloc[0].to_dict().items()}


def saturation_table(layout, scales, factors, widths):
    """The ground-truth demonstrator of ``layout`` (no inference) at every reward scale x horizon factor x width:
    its expected number of moves before it reaches the goal, the share of its trajectories at the goal at
    T, its mean entropy per move (nats) and the relative change of the moves when the reward scale doubles
    (``moves change``, nan for the largest scale)."""
    rows = []
    for w in widths:
        for f in factors:
            for b in scales:
                setup = Setting(b, f, w, layout).setup()
                m, goal = setup.grid.mdp, setup.grid.state(*setup.grid.goal)
                occ = state_action_visitation(m, setup.truth)
                pi = soft_policy(m, setup.truth)
                away = occ.sum(axis=2)[:, np.arange(m.n_states) != goal]
                with np.errstate(divide="ignore", invalid="ignore"):
                    ent = -np.where(pi > 0, pi * np.log(pi), 0.0).sum(axis=2)[:, np.arange(m.n_states) != goal]
                rows.append({"width": w, "horizon": setup.grid.mdp.horizon, "reward scale": b,
                             "moves": float(away.sum()), "at goal": float(_transpose_times(m, occ[-1].ravel())[goal]),
                             "entropy per move": float((away * ent).sum() / away.sum())})
    table = pd.DataFrame(rows)
    nxt = table.groupby(["width", "horizon"])["moves"].shift(-1)
    return table.assign(**{"moves change": (nxt - table["moves"]).abs() / table["moves"]})


def bottom_middle_f(reward_scale, horizon_factor, width):
    """F of the bottom-middle cell's constraint for the unconstrained agent (round 1, eq. 2.25), at the threshold a
    demonstration standing beside it on the bottom row gives it (eq. 3.3: the largest chance that a move other than
    the one into it slips there). The ground truth does not enter: C0 is unconstrained."""
    setup = Setting(reward_scale, horizon_factor, width, CHOSEN_LAYOUT).setup()
    m, g, bm = setup.grid.mdp, setup.grid, setup.bottom_middle
    beside = g.state(*(g.coords(bm)[0] - 1, 0))
    psi = float(np.delete(m.dense_transitions()[beside, :, bm], GRID_ACTIONS.index("E")).max())
    V = log_partition(m, np.stack([constraint_mask(m), constraint_mask(m, [bm], psi)], axis=2))[g.state(*g.start)]
    return float(np.exp(V[1] - V[0]))


def calibrated_scale(horizon_factor, width, target=F_BOTTOM_MIDDLE, low=0.125, high=16.0, steps=40):
    """The reward scale in [``low``, ``high``] at which :func:`bottom_middle_f` equals ``target``, by bisection on its
    logarithm (F falls as the scale grows); ``low`` or ``high`` when the target lies outside."""
    f = lambda b: bottom_middle_f(b, horizon_factor, width) - target          # noqa: E731
    if f(low) <= 0 or f(high) >= 0:
        return low if f(low) <= 0 else high
    a, b = np.log(low), np.log(high)
    for _ in range(steps):
        mid = (a + b) / 2
        a, b = (mid, b) if f(np.exp(mid)) > 0 else (a, mid)
    return float(np.exp((a + b) / 2))


def calibrated_settings(layouts, factors, widths):
    """Every layout x horizon factor x width at its :func:`calibrated_scale` (the second, post-hoc search)."""
    scales = {(f, w): calibrated_scale(f, w) for f in factors for w in widths}
    return [Setting(scales[f, w], f, w, lay) for w in widths for f in factors for lay in layouts]
