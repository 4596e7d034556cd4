"""Constraint inference from continuous recordings on the grid MDP: chapters 2-3's machinery as it is.

:func:`infer_cells` (``infer(..., model="cells")``) runs the whole pipeline -- discretize the dynamics
(:mod:`.discretization`), map the recordings onto the grid (:mod:`.mapping`), build the candidates with
their chance thresholds (:mod:`.candidates`), and add them greedily by F (Algorithm 4, eq. 2.25;
:func:`mutual.constraints.greedy_inference`) until the stop rule -- and returns a :class:`CellInference`
that reports every round in the constraints' own units. Its candidates are cell edges and its chance
thresholds are set per cell, where a cell's points leak into a region its demonstrated point never
entered; :mod:`.pointwise` says what that loses and :mod:`.inference` (the default) avoids it. This
model remains for chapter 3's cell candidates and as the comparison.
"""

import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .. import gather
from ..inference import greedy_inference
from .candidates import families_regions, region_candidates
from .discretization import discretize
from .mapping import to_demonstrations

#: above this much backup work (states x actions x candidates x steps) the compiled gather engine runs
GATHER_WORK = 2e7
#: with more candidates than this, prune="auto" prunes (the same choices; below it the bound costs more than it saves)
PRUNE_ABOVE = 128


@dataclass(eq=False)
class CellInference:
    """The outcome of :func:`infer`: the ``problem``, the grid ``mdp``, the ``mapped`` demonstrations,
    the ``candidates`` (:class:`~.candidates.RegionCandidates`), the greedy ``result``
    (:class:`~mutual.constraints.InferenceResult`), ``rounds`` [(log F, exact gain)] of every scored
    round including the one the stop rule refused, and ``seconds`` per stage."""

    problem: object
    mdp: object
    mapped: object
    candidates: object
    result: object
    rounds: list
    seconds: dict = field(default_factory=dict)

    def __repr__(self):
        chosen = "; ".join(self.candidates.label(k) for k in self.result.chosen) or "none"
        return f"CellInference({len(self.result.chosen)} chosen: {chosen}; stopped by {self.result.stop})"

    @property
    def states(self):
        """The aligned demonstrations (N, L+1, d)."""
        return self.mapped.states

    @property
    def stop(self):
        return self.result.stop

    def labels(self):
        """The chosen constraints in words, in order."""
        return [self.candidates.label(k) for k in self.result.chosen]

    def chosen_regions(self):
        """The regions (or None for cells) chosen, in order."""
        return [self.candidates.regions[k] for k in self.result.chosen]

    def ranking(self, top=None):
        """Every scored candidate of every round (best F first): round, rank, the constraint in its
        units, psi*, F, -log F, the exact per-demonstration log-likelihood gain, whether chosen."""
        described = self.candidates.table().set_index("candidate")
        rows = []
        for i, (log_f, gain) in enumerate(self.rounds):
            live = np.flatnonzero(np.isfinite(gain))
            order = live[np.argsort(log_f[live], kind="stable")][:top]
            for rank, k in enumerate(order, start=1):
                rows.append({"round": i + 1, "rank": rank, **described.loc[k].to_dict(), "F": float(np.exp(log_f[k])),
                             "neg_log_F": float(-log_f[k]), "exact_gain": float(gain[k]),
                             "chosen": bool(i < len(self.result.chosen) and k == self.result.chosen[i])})
        first = ["round", "rank", "kind", "constraint"]
        table = pd.DataFrame(rows)
        return table[first + [c for c in table.columns if c not in first]] if rows else table

    def chosen(self):
        """The accepted constraints, one row per round."""
        table = self.ranking()
        return table[table["chosen"]].drop(columns=["rank", "chosen"]).reset_index(drop=True) if len(table) else table


def choose_engine(mdp, n_candidates):
    """"gather" (compiled) for large backups when the MDP has few successors per state-action, else "numpy"."""
    work = mdp.n_states * mdp.n_actions * max(n_candidates, 1) * mdp.horizon
    return "gather" if work >= GATHER_WORK and gather.gather_form(mdp) is not None else "numpy"


def infer_cells(problem, recording, families=("bound",), rounds=5, min_gain=0.1, transitions=None, truncate=False,
                engine="auto", scheduler="auto", workers=None, progress=None, plane=(0, 1), every=2, radii=None,
                half_widths=None, thresholds="lemma", criterion="F", prune="auto"):
    """Greedy constraint inference on the grid MDP of ``problem`` from a :class:`~.recordings.Recording`.

    ``families``: candidate families ("bound", "disk", "box", "cell"; :mod:`.candidates`, with
    ``plane``, ``every``, ``radii``, ``half_widths``); ``rounds`` and ``min_gain`` (nats per
    demonstration) as in :func:`mutual.constraints.greedy_inference`; ``transitions``: S if already
    discretized (else :func:`.discretization.discretize` with ``scheduler``, ``workers``);
    ``truncate``: cut demonstrations to the shortest; ``thresholds``: "lemma" or "eq3.3"
    (:mod:`.thresholds`); ``criterion``: "F" (the thesis's ranking, eq. 2.25) or "likelihood" (the
    exact gain); ``prune``: score exactly only the candidates whose bound could win a round (the
    same choices; :mod:`mutual.constraints.bounds`), "auto": with more than ``PRUNE_ABOVE`` candidates
    and the ranking by F; ``engine``: "auto" (:func:`choose_engine`), "gather" or "numpy";
    ``progress(fraction, detail)``: called as chunks of the discretization and rounds finish (1.0 at the end).
    """
    say = progress or (lambda *args: None)
    seconds, start = {}, time.perf_counter()
    if transitions is None:
        transitions = discretize(problem, scheduler=scheduler, workers=workers,
                                 progress=lambda done, total: say(0.3 * done / total, f"discretizing {done}/{total} chunks"))
    seconds["discretize"] = time.perf_counter() - start
    say(0.3, f"discretized {problem.grid.n_cells} cells x {problem.n_actions} controls")
    start = time.perf_counter()
    mapped = to_demonstrations(problem, recording, transitions, truncate)
    mdp = problem.mdp(mapped.transitions)
    regions, cells = families_regions(problem.grid, families, plane, every, radii, half_widths)
    cand = region_candidates(mdp, mapped.demos, problem.grid, regions, cells, thresholds)
    seconds["candidates"] = time.perf_counter() - start
    say(0.4, f"{len(cand)} candidates")
    engine = choose_engine(mdp, len(cand)) if engine == "auto" else engine
    prune = (criterion == "F" and len(cand) > PRUNE_ABOVE) if prune == "auto" else prune
    scored = []

    def on_round(i, log_f, gain, best):
        scored.append((log_f, gain))
        say(0.4 + 0.6 * (i + 1) / max(rounds, 1), f"round {i + 1}: " + (cand.label(best) if best is not None else "stop rule"))

    start = time.perf_counter()
    result = greedy_inference(mdp, mapped.demos, cand.candidates, rounds, min_gain=min_gain, criterion=criterion,
                              prune=bool(prune), engine=engine, on_round=on_round)
    seconds["inference"] = time.perf_counter() - start
    say(1.0, "done")
    return CellInference(problem, mdp, mapped, cand, result, scored, seconds)
