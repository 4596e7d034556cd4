"""Constraint inference from continuous recordings: greedy maximum likelihood in the constraints' own units.

:func:`infer` (the default, ``model="points"``):

1. the recordings are aligned to dt and each demonstration's return is computed (:mod:`.evidence`);
2. the grid's cells become points of the deterministic system (:mod:`.pointwise`): the likelihood of
   the continuous demonstrations is exact up to Z on the grid, and chance thresholds are psi = 0 per
   point (eq. 3.3 on deterministic transitions) -- nothing is raised, nothing is dropped;
3. the reward: the file's at a given temperature, or (``temperature="fit"``, the default) the
   maximum-likelihood weights of its features (the squared errors per coordinate and controls, running and
   terminal: maximum-entropy inverse optimal control, eq. 2.8, concave in the weights; the goal stays the
   file's) under the constraints found so far -- first the temperature, then every weight, within a factor
   ``TEMPERATURE_RANGE`` of the file's at that temperature -- refitted under each proposed constraint. A hand-written controller is far less variable than a Boltzmann model
   at one temperature of the file's reward; fitting the weights lets the model be as precise as the
   demonstrator where it is (at its goal, along its path), which is where a less precise model would read
   avoidance into regions no demonstration entered;
4. each round proposes the most likely member of every family (:mod:`.search`: the tightest consistent
   bound per coordinate and side, the largest consistent disk or box at the best centre) and scores
   each by its exact log-likelihood gain at the round's reward; the best is scored again with the reward's
   weights refitted under it (the likelihood ratio with the weights profiled out: a constraint and the
   weights can explain the same avoidance, so a gain at fixed weights would understate it);
5. **stop rule**: the best candidate is accepted only if its gain is at least ``min_gain`` nats per
   demonstration *and* log(K / ALPHA) nats in all (K: the candidates scored in the round). The first is
   task relevance (Fig. 3.3: only constraints relevant to the task can be identified): with the gain
   -log F per demonstration above ``MIN_GAIN = log 2``, more than half of the model's trajectories from
   the demonstrated starts (geometric mean) would cross the constraint -- the *typical* unconstrained
   behaviour violates it, not only its tail. Regions that only the tail of a Boltzmann model enters are
   where a hand-written controller, far less variable than the model, differs from it most (a bound just
   past its goal, the space beside its path). The second is chance: without a constraint, and with the
   model right, the total gain of the tightest consistent member of a one-parameter family is
   exponentially distributed with mean 1 (the demonstrations' extreme is a maximum of independent draws),
   so K families exceed log(K / ALPHA) with probability <= ALPHA;
6. each accepted constraint gets a likelihood interval: the values of its parameter (a bound's value, an
   obstacle's size) whose likelihood is within a factor 1/ALPHA of the best. Under the model the true
   value lies in it with probability 1 - ALPHA (the likelihood ratio of the truth against the tightest
   consistent value is again exponential with mean 1).

``model="cells"`` runs chapters 2-3's own machinery on the discretized MDP instead (:mod:`.cells`).
"""

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from . import evidence as ev
from . import search
from .pointwise import file_weights, point_model
from .regions import Bound, boundary_distance

MIN_GAIN = math.log(2)   # nats per demonstration: the median unconstrained trajectory crosses it (docstring)
FIT, REFIT = 25, 10      # L-BFGS-B iterations of the reward's weights: first, and refitted under a candidate
ALPHA = 0.05        # chance of a false constraint per round; 1 - ALPHA: the interval's coverage
FAMILIES = ("bound", "disk", "box")
_PROFILE = np.array([0.0, 0.001, 0.003, 0.01, 0.02, 0.04, 0.07, 0.1, 0.15, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0])


@dataclass(eq=False)
class ContinuousInference:
    """The outcome of :func:`infer`: the ``problem``, the ``data`` (:class:`.evidence.Demonstrated`),
    ``accepted`` (per accepted constraint: region, gain, interval, its likelihood ``profile`` (values, total
    gains at the round's weights), weights), ``rounds`` (one table per round of every candidate scored),
    why it ``stop``-ped, the reward ``weights`` used per round (a temperature, or per-feature weights
    :func:`.pointwise.file_weights`), ``notes`` (what the user may need to change, in words) and ``seconds``
    per stage."""

    problem: object
    data: object
    accepted: list
    rounds: list
    stop: str
    weights: list
    notes: list = field(default_factory=list)
    seconds: dict = field(default_factory=dict)

    def __repr__(self):
        chosen = "; ".join(a["constraint"] for a in self.accepted) or "none"
        return f"ContinuousInference({len(self.accepted)} accepted: {chosen}; stopped by {self.stop})"

    @property
    def states(self):
        """The aligned demonstrations (N, L+1, d)."""
        return self.data.states

    def chosen_regions(self):
        """The accepted regions, in order."""
        return [a["region"] for a in self.accepted]

    def labels(self):
        """The accepted constraints in words, in order."""
        return [a["constraint"] for a in self.accepted]

    def ranking(self, top=None):
        """Every candidate of every round (best gain first): round, rank, kind, the constraint in its units,
        its numbers, the exact gain in all and per demonstration, F, the margin it needed, accepted."""
        tables = [t.head(top) if top else t for t in self.rounds]
        return pd.concat(tables, ignore_index=True) if tables else pd.DataFrame()

    def chosen(self):
        """The accepted constraints, one row per round, with their intervals."""
        rows = []
        for n, a in enumerate(self.accepted, start=1):
            table = self.rounds[n - 1]
            row = table[table["accepted"]].iloc[0].to_dict()
            rows.append({**row, "interval_low": a["interval"][0], "interval_high": a["interval"][1],
                         "interval_of": a["interval_of"]})
        return pd.DataFrame(rows)

    def best_rejected(self):
        """The candidate the stop rule refused (the best relevant one of the last round), or None."""
        if self.stop != "min_gain" or not self.rounds:
            return None
        table = self.rounds[-1]
        refused = table[np.isfinite(table["gain_refit"])]
        return refused.iloc[0].to_dict() if len(refused) else None


def _round_table(number, scored, grid, n_demos, needed, accepted, refitted, chosen=None):
    """One row per candidate of a round (most likely first): its exact gain at the round's reward in all
    and per demonstration, F; the best also its gain with the reward's weights refitted under it
    (``gain_refit``: the likelihood ratio with the weights profiled out, what the stop rule compares with
    ``needed``)."""
    rows = []
    order = sorted(range(len(scored)), key=lambda k: -np.nan_to_num(scored[k][1], nan=-np.inf, neginf=-np.inf))
    for rank, k in enumerate(order, start=1):
        region, gain = scored[k]
        top = region is chosen
        rows.append({"round": number, "rank": rank, "kind": region.kind, "constraint": region.describe(grid),
                     **region.fields(grid), "gain": gain, "gain_per_demo": gain / n_demos,
                     "F": math.exp(-gain / n_demos) if np.isfinite(gain) else math.nan,
                     "gain_refit": refitted if top else math.nan, "needed": needed, "accepted": bool(accepted and top)})
    return pd.DataFrame(rows)


def _candidates(model, data, logZ, regions, families, plane, tau, sizes):
    """[(region, total gain)] of the round's proposals and the number of regions scored."""
    grid = model.problem.grid
    score = lambda cands: ev.candidate_gains(model, data, logZ, regions, cands, tau)   # noqa: E731
    scored, tried = [], 0
    if "bound" in families:
        skip = {(r.dim, r.side) for r in regions if isinstance(r, Bound)}
        bounds = search.tightest_bounds(grid, data.samples, skip)
        scored += list(zip(bounds, score(bounds)))
        tried += len(bounds)
    for kind in ("disk", "box"):
        if kind in families:
            best, gain, n = search.search_obstacle(kind, plane, grid, data.path, score, sizes.get("largest"),
                                                   sizes.get("smallest"))
            tried += n
            if best is not None:
                scored.append((best, gain))
    return scored, tried


def likelihood_interval(model, data, logZ, regions, region, gain, tau, alpha=ALPHA):
    """``((low, high), reaches the box, (values, gains))``: the values of ``region``'s parameter
    (:func:`.search.size_of`) whose likelihood is within a factor 1/alpha of the best (module docstring),
    from the profile of the region loosened step by step (its values and total gains, best first)."""
    grid = model.problem.grid
    if isinstance(region, Bound):
        room = (grid.high[region.dim] - region.value) if region.side == "upper" else (region.value - grid.low[region.dim])
    else:
        room = search.size_of(region) * 0.999
    loosened = [search.widened(region, d * room) for d in _PROFILE[1:]]
    gains = np.r_[gain, ev.candidate_gains(model, data, logZ, regions, loosened, tau)]
    values = np.r_[search.size_of(region), [search.size_of(r) for r in loosened]]
    keep = np.isfinite(gains)
    near, far = search.profile_interval(values[keep], gains[keep], math.log(1 / alpha))
    return (min(near, far), max(near, far)), bool(abs(far - values[keep][-1]) < 1e-12), (values[keep], gains[keep])


def _fit(model, data, regions, temperature, start=None, reference=None):
    """(weights, ll, logZ, the temperature at the edge of its search, reference) under ``regions``: with
    ``temperature="fit"`` the maximum-likelihood feature weights from ``start`` (none: first the temperature,
    then every weight from the file's divided by it, which is the ``reference`` of the weights' caps); else
    the file's reward at that temperature."""
    if temperature != "fit":
        ll, logZ = ev.log_likelihood(model, data, regions, float(temperature))
        return float(temperature), ll, logZ, False, None
    edge, iterations = False, REFIT
    if start is None:
        tau, _, _, edge = ev.fit_temperature(model, data, regions, model.problem.reward.temperature)
        start = reference = file_weights(model.problem, tau)
        iterations = FIT
    weights, ll, logZ = ev.fit_weights(model, data, regions, start, reference, iterations)
    return weights, ll, logZ, edge, reference


def _check(families, rounds, min_gain, temperature):
    unknown = [f for f in families if f not in FAMILIES]
    if unknown:
        raise ValueError(f"families: unknown family {unknown[0]!r} for the point model; choose from {list(FAMILIES)} "
                         "('cell' candidates need model='cells')")
    if isinstance(rounds, bool) or not isinstance(rounds, (int, np.integer)) or rounds < 1:
        raise ValueError(f"rounds: must be an integer >= 1, got {rounds!r}")
    if isinstance(min_gain, bool) or not isinstance(min_gain, (int, float)) or not math.isfinite(min_gain) or min_gain < 0:
        raise ValueError(f"min_gain: must be a finite number of nats per demonstration >= 0, got {min_gain!r}")
    if temperature != "fit" and (isinstance(temperature, bool) or not isinstance(temperature, (int, float))
                                 or not math.isfinite(temperature) or temperature <= 0):
        raise ValueError(f"temperature: must be 'fit' or a positive number, got {temperature!r}")


def infer(problem, recording, families=("bound",), rounds=5, min_gain=MIN_GAIN, temperature="fit", plane=(0, 1),
          largest=None, smallest=None, truncate=False, progress=None, model="points", points=None, **cell_options):
    """Greedy maximum-likelihood constraint inference from a :class:`~.recordings.Recording` (module
    docstring). ``families``: "bound", "disk", "box" (obstacles in the coordinates ``plane``, sizes up to
    ``largest``, at least ``smallest``: default a quarter of the plane's smaller extent and its smallest
    cell); ``rounds``: at most this many constraints; ``min_gain``: nats per demonstration; ``temperature``:
    "fit" or a number (the file's is ``problem.reward.temperature``); ``truncate``: cut demonstrations
    to the shortest; ``progress(fraction, detail)``: called as the work advances (1.0 at the end);
    ``points``: the :func:`.pointwise.point_model` of ``problem`` if already built (reused across recordings).
    ``model="cells"``: chapters 2-3's grid MDP instead (:func:`.cells.infer_cells` with ``cell_options``)."""
    if model == "cells":
        from .cells import infer_cells
        return infer_cells(problem, recording, families=families, rounds=rounds, truncate=truncate, plane=plane,
                           progress=progress, **cell_options)
    if model != "points" or cell_options:
        raise ValueError(f"model: must be 'points' or 'cells', got {model!r}" if model != "points" else
                         f"options {sorted(cell_options)} apply to model='cells' only")
    _check(families, rounds, min_gain, temperature)
    say = progress or (lambda *args: None)
    seconds, start = {}, time.perf_counter()
    data = ev.demonstrated(problem, recording, truncate)
    pm = points if points is not None else \
        point_model(problem, lambda done, total: say(0.3 * done / total, f"integrating cells {done}/{total}"))
    if pm.problem is not problem:
        raise ValueError("points: built for another problem; pass point_model(problem)")
    seconds["model"] = time.perf_counter() - start
    start = time.perf_counter()
    regions, accepted, tables, temps, notes, stop = [], [], [], [], [], "rounds"
    _refuse_stranded(pm, data, recording)
    tau, ll, logZ, edge, reference = _fit(pm, data, regions, temperature)
    seconds["fit"] = time.perf_counter() - start
    say(0.4, "reward fitted" if temperature == "fit" else f"temperature {tau:g}")
    sizes = {"largest": largest, "smallest": smallest}
    start = time.perf_counter()
    for number in range(1, rounds + 1):
        temps.append(tau)
        scored, tried = _candidates(pm, data, logZ, regions, families, plane, tau, sizes)
        finite = [s for s in scored if np.isfinite(s[1])]
        if not finite:
            tables.append(_round_table(number, scored, problem.grid, data.n, math.nan, False, math.nan))
            stop = "no candidate"
            break
        best = max(finite, key=lambda s: s[1])
        refit = _fit(pm, data, regions + [best[0]], temperature, tau if temperature == "fit" else None, reference)
        gain = refit[1] - ll                         # the exact gain, the reward's weights refitted under it
        needed = max(min_gain * data.n, math.log(max(tried, 1) / ALPHA))
        ok = gain >= needed
        tables.append(_round_table(number, scored, problem.grid, data.n, needed, ok, gain, best[0]))
        say(0.4 + 0.6 * number / rounds, f"round {number}: {best[0].describe(problem.grid)}")
        if not ok:
            stop = "min_gain"
            break
        interval, open_, profile = likelihood_interval(pm, data, logZ, regions, best[0], best[1], tau)
        accepted.append({"region": best[0], "constraint": best[0].describe(problem.grid), "gain": gain,
                         "interval": interval, "interval_of": _parameter(best[0], problem.grid), "weights": tau,
                         "interval_reaches_box": open_, "profile": profile})
        regions.append(best[0])
        tau, ll, logZ = refit[:3]
    seconds["rounds"] = time.perf_counter() - start
    notes += _notes(problem, data, tables, accepted, edge, temperature)
    say(1.0, "done")
    return ContinuousInference(problem, data, accepted, tables, stop, temps, notes, seconds)


def _refuse_stranded(model, data, recording):
    """Refuse demonstrations the model cannot follow within the box (:func:`.evidence.stranded`: one backward pass,
    before any fit; Z = 0 there whatever the reward)."""
    p, dead = model.problem, ev.stranded(model, data)
    if not dead.size:
        return
    names = ", ".join(repr(str(recording.ids[i])) for i in dead[:5]) + (f" and {dead.size - 5} more" if dead.size > 5 else "")
    raise ValueError(f"{recording.source}: from where demonstration(s) {names} start (or end), every path of the model "
                     f"leaves the state box within the horizon (T = {p.horizon} steps of dt = {p.dt:g} s), so the model "
                     "cannot follow them; widen [state] low/high on the coordinates they approach, give the [control] "
                     "values the demonstrator used, or shorten [time] horizon")


def _parameter(region, grid):
    if isinstance(region, Bound):
        return f"{grid.names[region.dim]} ({grid.units[region.dim]})" if grid.units[region.dim] else grid.names[region.dim]
    return "radius" if region.kind == "disk" else "half-width"


def _notes(problem, data, tables, accepted, edge, temperature):
    """What the user may need to change, in words."""
    notes = []
    if edge:
        notes.append(f"the fitted temperature reached the edge of its search ({1 / ev.TEMPERATURE_RANGE:g} to "
                     f"{ev.TEMPERATURE_RANGE:g} times the file's {problem.reward.temperature:g}): the goal in [reward] "
                     "may not be what the demonstrator pursued")
    unscored = sum(int(t["gain"].isna().sum()) for t in tables)
    if unscored:
        notes.append(f"{unscored} candidate(s) could not be scored: no trajectory on the grid keeps in the box and "
                     "respects them from some demonstrated start or end, though the demonstration does; use finer cells "
                     "(--cells) or a wider box ([state] low/high)")
    if data.same_cell > 0.5:
        notes.append(f"{data.same_cell:.0%} of the recorded steps end in the cell they began in: the cells are coarse "
                     "for one step of dt; use finer cells or a longer dt")
    if data.inferred:
        notes.append(f"{data.inferred} steps had no recorded control: their rewards use the control of the set whose "
                     "step best explains the next state (this affects only the fitted reward)")
    for a in accepted:
        if a["interval_reaches_box"]:
            notes.append(f"the interval of {a['constraint']} reaches the edge of the box: the data cannot rule out a "
                         "looser one within it")
    if temperature != "fit":
        notes.append(f"reward fixed at the file's at temperature {temperature:g} (temperature='fit' fits its weights)")
    return notes


def boundary_errors(inference, truth):
    """For each true region in ``truth``: the boundary distance (:func:`.regions.boundary_distance`)
    of the first chosen region of the same kind and coordinates, or nan when none was chosen."""
    out = []
    for region in truth:
        errors = [boundary_distance(r, region) for r in inference.chosen_regions() if r is not None]
        errors = [e for e in errors if np.isfinite(e)]
        out.append(errors[0] if errors else np.nan)
    return out
