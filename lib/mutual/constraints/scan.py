"""Chapter 3's experiment over what the thesis leaves open (CLAIMS.md rules 2 and 8): the ground-truth
layout, the demonstrator's reward scale (inverse temperature), the horizon, the grid width and the
demonstration seed.

The scan was fixed before any of it ran (``notebooks/02_chance_thresholds.ipynb`` states it, with why
each range ends where it does): every cell of layout (:func:`.layouts.layout_family`, 12) x reward scale
(0.125-16, doubling) x horizon (4/3, 2, 8/3 and 4 times the width) x width (7-13) with seeds 0-2, and the
chosen set-up (layout "four", reward scale 1, T = 18, 9 x 9) with seeds 0-9. :func:`run_scan` runs them,
one world (reward scale, horizon, width) at a time with every layout and seed batched
(:mod:`.greedy_batch`) and cached on disk by parameters and code; :func:`measure` gives every number
chapter 3 reports for one run; :data:`STATEMENTS` says whether a run satisfies each claim's statement (the
rules of ``data/paper_claims.csv``); :func:`scan_summary` counts seeds and cells. The joint search and the
demonstrator's saturation are in :mod:`.joint`.
"""

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..cache import cache_folder, write_entry
from .candidates import constraint_candidates
from .demonstrations import sample_demonstrations
from .experiment import BLINDSPOT_SEEDS, BLINDSPOT_TASKS, N_DEMOS, SEED, WIDTH, chapter3
from .greedy_batch import BatchWorld, RunData, greedy_by_f
from .inference import greedy_inference
from .layouts import CHOSEN_LAYOUT, FAMILY_WIDTHS, layout_family, scaled_cell

SEEDS = tuple(range(10))                                   # at the chosen set-up
GRID_SEEDS = (0, 1, 2)                                     # in every cell of the grid
REWARD_SCALES = tuple(0.125 * 2.0 ** k for k in range(8))  # 0.125 .. 16
HORIZON_FACTORS = (4 / 3, 2.0, 8 / 3, 4.0)                 # T = round(factor * width): 12, 18, 24, 36 on 9 x 9
WIDTHS = FAMILY_WIDTHS                                     # 7, 9, 11, 13
ROUNDS = 8

# the thesis's numbers and the tolerances of data/paper_claims.csv (a test keeps them equal)
F_BOTTOM_MIDDLE, F_BOTTOM_MIDDLE_TOL = 0.29, 0.05
F_RETRACTS, F_RETRACTS_TOL = 0.96, 0.03
GAIN_DROP = 10.0
RECOVERY_ROUND, RETRACTION_ROUND = 4, 5                    # "by the fifth iteration", "after the fourth constraint"


@dataclass(frozen=True)
class Setting:
    """One cell of the scan: the demonstrator's ``reward_scale``, the horizon as a multiple of the grid
    ``width`` (``horizon_factor``), the ``width`` and the ground-truth ``layout``."""

    reward_scale: float = 1.0
    horizon_factor: float = 2.0
    width: int = WIDTH
    layout: object = field(default=CHOSEN_LAYOUT)

    @property
    def horizon(self):
        return int(round(self.horizon_factor * self.width))

    @property
    def world(self):
        return (float(self.reward_scale), self.horizon, int(self.width))

    def label(self):
        return f"layout {self.layout.name}, scale {self.reward_scale:g}, T = {self.horizon}, {self.width}x{self.width}"

    def setup(self, **kwargs):
        return chapter3(self.layout, reward_scale=self.reward_scale, horizon=self.horizon, width=self.width, **kwargs)


CHOSEN = Setting()
CHOSEN_SEED = SEED


def grid_scan(layouts=None, scales=REWARD_SCALES, factors=HORIZON_FACTORS, widths=WIDTHS):
    """Every cell of layout x reward scale x horizon factor x width (1536 with the defaults), the chosen set-up
    among them."""
    layouts = layout_family() if layouts is None else layouts
    return [Setting(b, h, w, lay) for w in widths for h in factors for b in scales for lay in layouts]


def axes_scan(layouts=None):
    """The cells that vary one setting at a time from the chosen set-up: every layout, reward scale,
    horizon factor and width (25 with the defaults)."""
    layouts = layout_family() if layouts is None else layouts
    c = CHOSEN
    cells = [Setting(c.reward_scale, c.horizon_factor, c.width, lay) for lay in layouts]
    cells += [Setting(b, c.horizon_factor, c.width) for b in REWARD_SCALES if b != c.reward_scale]
    cells += [Setting(c.reward_scale, h, c.width) for h in HORIZON_FACTORS if h != c.horizon_factor]
    return cells + [Setting(c.reward_scale, c.horizon_factor, w) for w in WIDTHS if w != c.width]


def _kind_index(key):
    return key[0], key[1]


def _finish(relevant, truth):
    """``until`` for :func:`.greedy_batch.greedy_by_f`: stop once every task-relevant truth is chosen, one
    more choice made, and an untrue constraint chosen (nothing measured can change after that)."""
    def until(i, chosen):
        kinds = [_kind_index(k) for k in chosen]
        done = [kinds.index(r) for r in relevant[i] if r in kinds]
        return (len(done) == len(relevant[i]) and max(done) < len(kinds) - 1
                and any(k not in truth[i] for k in kinds))
    return until


def truth_keys(setup):
    """(relevant, upper) as (kind, index) pairs: the task-relevant truth (bottom-middle cell first) and the
    upper-half blind spot."""
    relevant = [("state", s) for s in (setup.bottom_middle,) + setup.lower] + [("action", a) for a in setup.actions]
    return relevant, [("state", s) for s in setup.upper]


def measure(setting, seed, setup, demos, run, greedy):
    """Every number chapter 3 reports, for one run (a dict; nan or None where the run did not reach it)."""
    relevant, upper = truth_keys(setup)
    truth = set(relevant) | set(upper)
    chosen = [_kind_index(k) for k in greedy.chosen]
    first = {_kind_index(k): v for k, v in greedy.first_round.items()}
    states = {k: v for k, v in first.items() if k[0] == "state" and np.isfinite(v)}
    rec = max((chosen.index(r) + 1 for r in relevant), default=0) if all(r in chosen for r in relevant) else None
    untrue = next((n + 1 for n, k in enumerate(chosen) if k not in truth), None)
    before = chosen[:untrue - 1] if untrue else chosen
    next_ok = rec is not None and rec < len(chosen)
    log_f = np.array(greedy.log_f)
    psi_rejects = sum(1 for k, v in first.items() if k[0] == "state" and np.isnan(v) and run.psi[k[1]] < 1)
    return {"layout": setting.layout.name, "reward scale": setting.reward_scale, "horizon": setting.horizon,
            "width": setting.width, "seed": seed,
            "at goal": float(np.mean(demos.states[:, -1] == setup.grid.state(*setup.grid.goal))),
            "first is bottom-middle": bool(chosen[:1] == relevant[:1]),
            "first state is bottom-middle": bool(states) and min(states, key=states.get) == relevant[0],
            "F bottom-middle": float(np.exp(first.get(relevant[0], np.nan))),
            "recovered at": rec, "first untrue at": untrue,
            "F first untrue": float(np.exp(log_f[untrue - 1])) if untrue else np.nan,
            "F next": float(np.exp(log_f[rec])) if next_ok else np.nan,
            "next untrue": bool(chosen[rec] not in truth) if next_ok else None,
            "gain drop": (float(log_f[rec - 1] / log_f[rec]) if log_f[rec] < 0 else np.inf) if next_ok else np.nan,
            "upper feasible": sum(bool(np.isfinite(first.get(u, np.nan))) for u in upper),
            "upper identified": sum(u in before for u in upper),
            "psi* rejects": int(psi_rejects), "states with psi* < 1": int(np.sum(run.psi < 1)),
            "chosen": "; ".join(setup.grid.label(*k) for k in chosen)}


def world_rows(settings, seeds, n_demos=N_DEMOS, rounds=ROUNDS):
    """:func:`measure` for every setting of one world (the same reward scale, horizon and width) and seed,
    the greedy runs batched on one :class:`.greedy_batch.BatchWorld`."""
    setups = [s.setup() for s in settings]
    if len({s.world for s in settings}) != 1:
        raise ValueError("settings: world_rows takes the settings of one world (reward scale, horizon, width)")
    jobs = [(st, su, seed, sample_demonstrations(su.grid.mdp, n_demos, su.truth, rng=seed))
            for st, su in zip(settings, setups) for seed in seeds]
    runs = [RunData.of(su.grid.mdp, d) for _, su, _, d in jobs]
    keys = [truth_keys(su) for _, su, _, _ in jobs]
    until = _finish([r for r, _ in keys], [set(r) | set(u) for r, u in keys])
    greedy = greedy_by_f(BatchWorld(setups[0].grid.mdp), runs, rounds, until)
    return [measure(st, seed, su, d, run, g) for (st, su, seed, d), run, g in zip(jobs, runs, greedy)]


def _fingerprint():
    """The source of every module a scan's numbers depend on: a cache entry is valid for this code only."""
    here = Path(__file__).parent
    names = ("scan", "greedy_batch", "layouts", "experiment", "gridworld", "demonstrations", "chance", "mdp",
             "fast", "backup", "feasibility")
    return hashlib.sha256(b"".join((here / f"{n}.py").read_bytes() for n in names)).hexdigest()[:16]


def _cached_world_rows(settings, seeds, n_demos, rounds):
    params = json.dumps({"world": settings[0].world, "layouts": [repr(s.layout) for s in settings],
                         "seeds": list(seeds), "n_demos": n_demos, "rounds": rounds, "code": _fingerprint()})
    folder = cache_folder("chapter3-scan")
    path = None if folder is None else folder / (hashlib.sha256(params.encode()).hexdigest()[:24] + ".json")
    if path is not None and path.is_file():
        try:
            stored = json.loads(path.read_text())
            if stored.get("params") == params:
                return stored["rows"]
        except (OSError, ValueError):
            pass
    rows = world_rows(settings, seeds, n_demos, rounds)
    if path is not None:
        write_entry(path, lambda tmp: Path(tmp).write_text(json.dumps({"params": params, "rows": rows})))
    return rows


def run_scan(settings, seeds, n_demos=N_DEMOS, rounds=ROUNDS, cache=True):
    """:func:`measure` for every setting and seed, as a DataFrame (one row per run), one world at a time;
    with ``cache`` each world's rows are kept on disk (:mod:`mutual.cache`) by parameters and code."""
    worlds = {}
    for s in settings:
        worlds.setdefault(s.world, []).append(s)
    run = _cached_world_rows if cache else world_rows
    return pd.DataFrame([row for group in worlds.values() for row in run(group, tuple(seeds), n_demos, rounds)])


def blindspot_run(setting, seed, n_demos=N_DEMOS, rounds=ROUNDS + 4):
    """The blind-spot experiment (Figure 3.3's caption) on one set-up: the first task's demonstrations
    (``seed``) pooled with those of the two upper-half tasks (seeds ``BLINDSPOT_SEEDS + 10 seed``, so seed 0
    is the main run), greedy on the pooled likelihood; how many upper-half truths it identifies (chosen
    before its first untrue choice)."""
    first = setting.setup()
    w = setting.width
    mdps, sets = [first.grid.mdp], [sample_demonstrations(first.grid.mdp, n_demos, first.truth, rng=seed)]
    for name, (start, goal) in BLINDSPOT_TASKS.items():
        task = setting.setup(start=scaled_cell(start, w), goal=scaled_cell(goal, w))
        mdps.append(task.grid.mdp)
        sets.append(sample_demonstrations(task.grid.mdp, n_demos, task.truth, rng=BLINDSPOT_SEEDS[name] + 10 * seed))
    cand = constraint_candidates(mdps, sets)
    _, upper, truth = first.candidate_ids(cand)
    result = greedy_inference(mdps, sets, cand, rounds, until=lambda chosen: any(k not in truth for k in chosen))
    return {"layout": setting.layout.name, "reward scale": setting.reward_scale, "horizon": setting.horizon,
            "width": setting.width, "seed": seed,
            "upper identified, pooled": sum(k in upper for k in result.before_first_untrue(truth))}


def run_blindspot(settings, seeds, n_demos=N_DEMOS):
    """:func:`blindspot_run` for every setting and seed, as a DataFrame."""
    return pd.DataFrame([blindspot_run(s, seed, n_demos) for s in settings for seed in seeds])


def _close(value, target, tol):
    return bool(np.isfinite(value) and abs(value - target) <= tol)


# whether one run satisfies each claim's statement (the rules of data/paper_claims.csv)
STATEMENTS = {
    "c3-first-constraint-bottom-middle": lambda r: r["first is bottom-middle"],
    "c3-first-state-constraint-bottom-middle": lambda r: r["first state is bottom-middle"],
    "c3-f-bottom-middle": lambda r: _close(r["F bottom-middle"], F_BOTTOM_MIDDLE, F_BOTTOM_MIDDLE_TOL),
    "c3-f-retracts": lambda r: _close(r["F next"], F_RETRACTS, F_RETRACTS_TOL),
    "c3-gain-order-of-magnitude": lambda r: bool(np.isfinite(r["gain drop"]) and r["gain drop"] >= GAIN_DROP),
    "c3-candidate-after-fourth-untrue": lambda r: r["next untrue"] is True,
    "c3-ground-truth-fifth-iteration": lambda r: r["recovered at"] == RECOVERY_ROUND,
    "c3-blindspot-upper-three": lambda r: r["upper feasible"] == 3 and r["upper identified"] == 0,
    "c3-psi-star-lowest-feasible": lambda r: r["psi* rejects"] == 0,
}
BLINDSPOT_STATEMENT = ("c3-blindspot-new-task", lambda r: r["upper identified, pooled"] == 3)

JOINT = ("c3-first-constraint-bottom-middle", "c3-f-bottom-middle", "c3-ground-truth-fifth-iteration", "c3-f-retracts",
         "c3-gain-order-of-magnitude")


def joint_statement(row, claims=JOINT):
    """All of chapter 3's numbers in one run (``claims``, default :data:`JOINT`): the bottom-middle cell first
    with F about 0.29, the four task-relevant truths in rounds 1-4, then F retracting to about 0.96 with a
    gain that drops by an order of magnitude."""
    return all(STATEMENTS[c](row) for c in claims)


CELL = ["layout", "reward scale", "horizon", "width"]


def holding_table(table, statement):
    """Per cell: in how many seeds ``statement(row)`` holds, and of how many (columns ``holds``, ``seeds``)."""
    ok = table.assign(ok=[bool(statement(r)) for r in table.to_dict("records")])
    out = ok.groupby(CELL, sort=False)["ok"].agg(holds="sum", seeds="size").reset_index()
    return out.astype({"holds": int, "seeds": int})


def holding_pivot(table, statement):
    """:func:`holding_table` laid out for reading: one row per layout and width, one column per reward scale,
    each entry "horizons where it holds for every seed / horizons"."""
    cells = holding_table(table, statement)
    cells["robust"] = cells["holds"] >= np.ceil(0.9 * cells["seeds"])
    agg = cells.groupby(["layout", "width", "reward scale"], sort=False)["robust"].agg(["sum", "size"]).reset_index()
    agg["entry"] = [f"{int(a)}/{int(b)}" for a, b in zip(agg["sum"], agg["size"])]
    pivot = agg.pivot(index=["layout", "width"], columns="reward scale", values="entry")
    pivot.columns = [f"scale {b:g}" for b in pivot.columns]
    return pivot.reset_index()


def scan_summary(table, statement, chosen_table, chosen=CHOSEN, table_name=""):
    """The scan of one claim (``mutual.compendium.claims.check_scan``'s form): ``seeds`` [holding, total]
    at the ``chosen`` set-up (from ``chosen_table``, its seeds 0-9), ``settings`` [cells of ``table`` where it
    holds for at least 9 of 10 seeds (all of a cell's seeds when it has 3), cells] and ``flips``."""
    at = holding_table(chosen_table, statement)
    at = at[(at["layout"] == chosen.layout.name) & (at["reward scale"] == chosen.reward_scale)
            & (at["horizon"] == chosen.horizon) & (at["width"] == chosen.width)]
    if len(at) != 1:
        raise ValueError(f"chosen_table: the chosen set-up ({chosen.label()}) is not one of its cells")
    cells = holding_table(table, statement)
    robust = cells["holds"] >= np.ceil(0.9 * cells["seeds"])
    few, verb = (cells[robust], "holds only") if 0 < robust.sum() < (~robust).sum() else (cells[~robust], "fails")
    shown = "; ".join(f"{r['layout']}, scale {r['reward scale']:g}, T = {r['horizon']}, {r['width']}x{r['width']}: "
                      f"{r['holds']}/{r['seeds']} seeds" for r in few.head(6).to_dict("records"))
    flips = f"{verb} in {len(few)} of {len(cells)} cells: {shown}" + (" ..." if len(few) > 6 else "") if (~robust).any() else ""
    return {"table": table_name, "seeds": [int(at["holds"].iloc[0]), int(at["seeds"].iloc[0])],
            "settings": [int(robust.sum()), int(len(cells))], "flips": flips}
