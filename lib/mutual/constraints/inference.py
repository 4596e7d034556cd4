"""Greedy maximum-likelihood constraint inference (Section 2.4, Chapter 3's chance thresholds):
the greedy iterative procedure that adds the best-ranked candidate per round
(:func:`greedy_inference`, on one task or on pooled tasks), its history
(:class:`InferenceResult`), and :func:`horizon_sensitivity`, its first round as the (unstated)
horizon T varies. The candidates themselves are built in :mod:`.candidates`."""

import numbers
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .backup import ENGINES, rank_candidates
from .bounds import gain_bounds
from .feasibility import infeasible_candidates
from .candidates import Candidates, as_tasks, constraint_candidates
from .demonstrations import sample_demonstrations
from .mdp import check_mask

__all__ = ["Candidates", "InferenceResult", "constraint_candidates", "greedy_inference", "horizon_sensitivity",
           "latest_recovery", "score_candidates"]


@dataclass(frozen=True, eq=False)
class InferenceResult:
    """Greedy inference history: ``chosen[i]`` the candidate added in round i,
    ``log_f[i]`` (K,) every candidate's mean log F in round i (nan: infeasible, already chosen
    or -- with pruning -- not scored because its bound could not win), ``gain[i]`` (K,) their
    exact per-demonstration log-likelihood gains, ``mask`` the final constraint mask Phi_C
    (constraints only; each MDP's unavailable actions are added by the backups), ``stop`` why
    the run ended ("rounds", "min_gain", "no feasible candidate" or "until") and ``scored[i]`` how many
    candidates were scored exactly in round i (the last entry: the round that stopped it)."""

    chosen: list
    log_f: list
    gain: list
    mask: np.ndarray
    stop: str = "rounds"
    scored: list = field(default_factory=list)

    def __repr__(self):
        F = ", ".join(f"{v:.3g}" for v in self.F)
        return f"InferenceResult({len(self.chosen)} constraints chosen, F = [{F}], stopped by {self.stop})"

    @property
    def gains(self):
        """-mean log F of each chosen constraint: its per-demonstration log-likelihood
        gain as the thesis counts it (eq. 2.25)."""
        return np.array([-lf[k] for lf, k in zip(self.log_f, self.chosen)])

    @property
    def exact_gains(self):
        """The exact per-demonstration log-likelihood gain of each chosen constraint."""
        return np.array([g[k] for g, k in zip(self.gain, self.chosen)])

    @property
    def F(self):
        """F of each chosen constraint (geometric mean over the demonstrations' starts)."""
        return np.exp(-self.gains)

    def recovered_at(self, targets):
        """The round (1-based) by which every candidate in ``targets`` has been chosen, or None."""
        rounds = [self.chosen.index(k) + 1 if k in self.chosen else None for k in targets]
        return None if None in rounds else max(rounds, default=0)

    def before_first_untrue(self, truth):
        """The chosen candidates up to (not including) the first one outside ``truth``."""
        out = []
        for k in self.chosen:
            if k not in truth:
                break
            out.append(k)
        return out

    def summary(self, relevant, truth):
        """How the run went against a known ground truth (candidate numbers): the round by
        which all ``relevant`` ones were chosen, then the next choice's F, whether it is
        outside ``truth``, and the ratio of -log F of the last relevant choice to the next's.
        Entries that the run did not reach are the string "not reached"."""
        at = self.recovered_at(relevant)
        if at is None or at >= len(self.chosen):
            return dict(recovered_at="not reached" if at is None else at, F_next="not reached",
                        next_untrue="not reached", gain_drop="not reached")
        gains = self.gains
        return dict(recovered_at=at, F_next=float(self.F[at]), next_untrue=bool(self.chosen[at] not in truth),
                    gain_drop=float(gains[at - 1] / gains[at]))

    def n_accepted(self, min_gain):
        """Rounds before the stopping rule fires: the first gain below ``min_gain`` ends inference."""
        below = np.flatnonzero(self.gains < min_gain)
        return int(below[0]) if below.size else len(self.chosen)


def latest_recovery(rounds):
    """The worst case over runs of :meth:`InferenceResult.summary`'s ``recovered_at``:
    the latest round, or "not reached" if any run did not recover its targets."""
    rounds = list(rounds)
    if not rounds:
        raise ValueError("rounds: need at least one run")
    return "not reached" if "not reached" in rounds else int(max(rounds))


def score_candidates(tasks, candidates, idx, mask, engine="auto"):
    """Mean log F and exact gain per demonstration (Algorithm 4, :func:`rank_candidates`) of the
    candidates ``idx`` over pooled ``tasks`` [(mdp, demos), ...], weighted by demonstrations."""
    total = sum(d.n for _, d in tasks)
    log_f, gain = np.zeros(len(idx)), np.zeros(len(idx))
    columns = candidates.forbidden_matrix[:, idx]
    for m, d in tasks:
        lf, g = rank_candidates(m, d, columns, mask, engine)
        log_f += lf * d.n / total
        gain += g * d.n / total
    return log_f, gain


def _check_inputs(tasks, candidates, rounds, min_gain, criterion, prune, engine):
    if not isinstance(candidates, Candidates):
        raise TypeError(f"candidates: must be Candidates (from constraint_candidates), got {type(candidates).__name__}")
    X, A = tasks[0][0].n_states, tasks[0][0].n_actions
    if tuple(candidates.shape) != (X, A):
        raise ValueError(f"candidates: built for (X, A) = {tuple(candidates.shape)}, the MDP has {(X, A)}")
    if isinstance(rounds, bool) or not isinstance(rounds, (int, np.integer)) or rounds < 0:
        raise ValueError(f"rounds: must be a non-negative integer, got {rounds!r}")
    if min_gain is not None and (isinstance(min_gain, bool) or not isinstance(min_gain, numbers.Real)
                                 or not np.isfinite(min_gain)):
        raise ValueError(f"min_gain: must be None (no stopping rule) or a finite number of nats per "
                         f"demonstration, got {min_gain!r}")
    if criterion not in ("F", "likelihood"):
        raise ValueError(f"criterion: must be 'F' or 'likelihood', got {criterion!r}")
    if not isinstance(prune, (bool, np.bool_)):
        raise TypeError(f"prune: must be True or False, got {prune!r}")
    if prune and criterion != "F":
        raise ValueError("prune: the gain bound holds for the ranking by F only; use criterion='F'")
    if engine not in ENGINES:
        raise ValueError(f"engine: must be one of {ENGINES}, got {engine!r}")


def _pruned_round(tasks, candidates, idx, mask, floor, engine, first=32):
    """Score only the candidates that keep the demonstrations feasible (:mod:`.feasibility`) and
    whose bound (:mod:`.bounds`) could beat the best exact score: the ``first`` best-bounded ones,
    then every other one whose bound reaches the best score so far."""
    total = sum(d.n for _, d in tasks)
    columns = candidates.forbidden_matrix[:, idx]
    dead = np.zeros(idx.size, dtype=bool)
    for m, d in tasks:
        dead |= infeasible_candidates(m, d, mask, columns)
    bound = np.full(idx.size, -np.inf)
    bound[~dead] = sum(gain_bounds(m, d, mask, columns[:, ~dead]) * d.n / total for m, d in tasks)
    order = np.argsort(-bound, kind="stable")
    log_f, gain = np.full(idx.size, np.nan), np.full(idx.size, -np.inf)
    head = order[:first][bound[order[:first]] >= floor]
    log_f[head], gain[head] = score_candidates(tasks, candidates, idx[head], mask, engine)
    best = np.nanmax(np.where(np.isfinite(gain[head]), -log_f[head], -np.inf), initial=-np.inf)
    rest = order[first:][bound[order[first:]] >= max(best, floor)]
    if rest.size:
        log_f[rest], gain[rest] = score_candidates(tasks, candidates, idx[rest], mask, engine)
    return log_f, gain, head.size + rest.size, dead


def greedy_inference(mdp, demos, candidates, rounds, min_gain=None, base_mask=None, criterion="F", prune=False,
                     engine="auto", on_round=None, until=None):
    """Greedy iterative constraint inference (Section 2.4, after Scobee and Sastry).

    Each round scores every feasible, not yet chosen candidate by Algorithm 4 and adds
    the best: the smallest F (``criterion="F"``, the thesis's ranking, eq. 2.25) or the
    largest exact log-likelihood gain (``criterion="likelihood"``).

    **Stopping rule**: after ``rounds`` rounds; or -- when ``min_gain`` (a finite number of
    nats per demonstration) is given -- as soon as the best candidate's gain -log F falls
    below ``min_gain`` (F > exp(-min_gain)): it is not added and inference ends
    (``result.stop == "min_gain"``). Once only untrue constraints remain, F retracts towards 1.
    Inference also ends when no feasible candidate is left.

    ``mdp`` and ``demos`` may be equally long lists: demonstrations of several tasks on the
    same dynamics, pooled (each candidate's log F and gain are averaged over all
    demonstrations). ``prune=True`` (ranking by F only) scores exactly only the candidates
    whose upper bound on -log F (:mod:`.bounds`) could win the round: the same choices, far
    fewer backups on large worlds; unscored candidates get log F = nan in the history.
    ``engine`` as in :func:`mutual.constraints.backup.log_partition`. ``on_round``, if given, is
    called after each round is scored as ``on_round(i, log_f, gain, best)`` (``best``: the candidate
    added, or None when this round ends inference): for progress, and to see the refused round.
    ``until``: a function of the list of chosen candidates that ends inference (``result.stop ==
    "until"``) once it returns True.
    """
    tasks = as_tasks(mdp, demos)
    _check_inputs(tasks, candidates, rounds, min_gain, criterion, prune, engine)
    notify = on_round or (lambda *args: None)
    mask = check_mask(tasks[0][0], base_mask, "base_mask") | ~tasks[0][0].allowed
    available = candidates.feasible.copy()
    chosen, history, gains, scored, stop = [], [], [], [], "rounds"
    floor = -np.inf if min_gain is None else min_gain
    for _ in range(rounds):
        idx = np.flatnonzero(available)
        log_f, gain = np.full(len(candidates), np.nan), np.full(len(candidates), -np.inf)
        if prune:
            log_f[idx], gain[idx], n_scored, dead = _pruned_round(tasks, candidates, idx, mask, floor, engine)
            available[idx[dead]] = False     # infeasible now, so under every tighter mask too
        else:
            (log_f[idx], gain[idx]), n_scored = score_candidates(tasks, candidates, idx, mask, engine), idx.size
        scored.append(int(n_scored))
        if not np.isfinite(gain).any():
            stop = "min_gain" if prune and n_scored == 0 and idx.size else "no feasible candidate"
            notify(len(chosen), log_f, gain, None)
            break
        score = np.where(np.isfinite(gain), -log_f if criterion == "F" else gain, -np.inf)
        best = int(np.argmax(score))
        if min_gain is not None and -log_f[best] < min_gain:
            stop = "min_gain"
            notify(len(chosen), log_f, gain, None)
            break
        notify(len(chosen), log_f, gain, best)
        chosen.append(best)
        history.append(log_f)
        gains.append(gain)
        mask &= ~candidates.forbidden_matrix[:, best].toarray().reshape(mask.shape)
        available[best] = False
        if until is not None and until(chosen):
            stop = "until"
            break
    return InferenceResult(chosen, history, gains, mask, stop, scored)


def horizon_sensitivity(grid_at, horizons, truth, n_demos, seed, watch_state):
    """The first round of greedy inference (ranked by F) as the horizon T varies.

    For each T in ``horizons``: ``grid_at(T)`` builds the gridworld, ``n_demos``
    demonstrations are drawn (generator ``seed``) from its Boltzmann demonstrator
    under the ground truth ``truth`` (Phi_C, (X, A)), and every chance candidate
    (eq. 3.3) is ranked by F (Algorithm 4, eq. 2.25). Returns a DataFrame with one row
    per T: the share of demonstrations ending at the goal, ``watch_state``'s psi* and
    round-1 F (nan where that candidate is infeasible), and the first choice with its F.
    """
    horizons = [int(T) for T in horizons]
    if not horizons or min(horizons) < 1:
        raise ValueError(f"horizons: need one or more horizons >= 1, got {horizons!r}")
    rows = []
    for T in horizons:
        grid = grid_at(T)
        demos = sample_demonstrations(grid.mdp, n_demos, truth, rng=seed)
        cand = constraint_candidates(grid.mdp, demos)
        first = greedy_inference(grid.mdp, demos, cand, 1)
        F = np.exp(first.log_f[0])
        watched = cand.find("state", watch_state)
        best = first.chosen[0]
        rows.append({"horizon T": T, "at goal": float(np.mean(demos.states[:, -1] == grid.state(*grid.goal))),
                     "psi* watched": float(cand.psi[watched]), "F watched, round 1": float(F[watched]),
                     "first choice": grid.label(cand.kind[best], cand.index[best]), "F first choice": float(F[best])})
    return pd.DataFrame(rows)
