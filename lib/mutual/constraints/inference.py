"""Greedy maximum-likelihood constraint inference (Section 2.4, Chapter 3's chance thresholds):
the candidate constraints a demonstration set allows, and the greedy iterative procedure that
adds the best-ranked one per round (:func:`greedy_inference`); :func:`horizon_sensitivity` shows
its first round as the (unstated) horizon T varies."""

from dataclasses import dataclass

import numpy as np
import pandas as pd

from .chance import chance_forbidden, max_likelihood_thresholds
from .backup import rank_candidates
from .demonstrations import check_demonstrations, sample_demonstrations
from .mdp import check_mask


@dataclass(frozen=True, eq=False)
class Candidates:
    """Single-constraint hypotheses C+ (Section 2.4.1).

    ``kind[k]`` is "state" or "action", ``index[k]`` the state or action, ``psi[k]``
    the state's chance threshold (nan for actions), ``forbidden`` (X, A, K) the actions
    each forbids, ``feasible[k]`` whether it keeps every demonstration possible.
    """

    kind: np.ndarray
    index: np.ndarray
    psi: np.ndarray
    forbidden: np.ndarray
    feasible: np.ndarray

    def __len__(self):
        return self.kind.size

    def label(self, k):
        return f"{self.kind[k]} {self.index[k]}"

    def find(self, kind, index):
        """The candidate number of the ``kind`` ("state"/"action") constraint on ``index``."""
        hit = np.flatnonzero((self.kind == kind) & (self.index == index))
        if hit.size != 1:
            raise ValueError(f"kind/index: no single {kind} candidate on {index}")
        return int(hit[0])


def constraint_candidates(mdp, demos, states=True, actions=True, chance=True):
    """One candidate per state (a chance constraint, eq. 3.1) and per action (forbidden everywhere).

    With ``chance`` each state's threshold is the maximum-likelihood psi*(x) of
    eq. (3.3) (Lemma 3.2.1); otherwise psi = 0, the hard state constraints of
    Chapter 2. A candidate is infeasible -- never chosen -- if it forbids a
    demonstrated action in its state (a demonstrated transition exceeds its
    threshold), forbids a demonstrated action, or (psi = 0) forbids a demonstrated state.
    """
    check_demonstrations(mdp, demos)
    X, A = mdp.n_states, mdp.n_actions
    state_ids = np.arange(X) if states else np.empty(0, dtype=int)
    action_ids = np.arange(A) if actions else np.empty(0, dtype=int)
    psi = max_likelihood_thresholds(mdp, demos)[state_ids] if chance else np.zeros(state_ids.size)
    forbidden_actions = np.zeros((X, A, action_ids.size), dtype=bool)
    forbidden_actions[:, action_ids, np.arange(action_ids.size)] = True
    forbidden = np.concatenate([chance_forbidden(mdp, state_ids, psi), forbidden_actions], axis=2)
    x, a = demos.pairs()
    feasible = ~forbidden[x, a].any(axis=0)
    visited = np.zeros(X, dtype=bool)
    visited[demos.states.ravel()] = True
    feasible[: state_ids.size] &= ~((psi == 0) & visited[state_ids])
    kind = np.array(["state"] * state_ids.size + ["action"] * action_ids.size)
    return Candidates(kind, np.concatenate([state_ids, action_ids]),
                      np.concatenate([psi, np.full(action_ids.size, np.nan)]), forbidden, feasible)


@dataclass(frozen=True, eq=False)
class InferenceResult:
    """Greedy inference history: ``chosen[i]`` the candidate added in round i,
    ``log_f[i]`` (K,) every candidate's mean log F in round i (nan: infeasible or chosen),
    ``gain[i]`` (K,) their exact per-demonstration log-likelihood gains, ``mask`` the final Phi_C."""

    chosen: list
    log_f: list
    gain: list
    mask: np.ndarray

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


def greedy_inference(mdp, demos, candidates, rounds, min_gain=None, base_mask=None, criterion="F"):
    """Greedy iterative constraint inference (Section 2.4, after Scobee and Sastry).

    Each round scores every feasible, not yet chosen candidate by Algorithm 4 and adds
    the best: the smallest F (``criterion="F"``, the thesis's ranking, eq. 2.25) or the
    largest exact log-likelihood gain (``criterion="likelihood"``). Stopping rule: after
    ``rounds`` rounds, or -- when ``min_gain`` is given -- before adding a constraint
    whose gain -log F falls below ``min_gain`` nats per demonstration (F > exp(-min_gain)):
    once only untrue constraints remain, F retracts towards 1.
    """
    check_demonstrations(mdp, demos)
    if not isinstance(rounds, (int, np.integer)) or rounds < 0:
        raise ValueError(f"rounds: must be a non-negative integer, got {rounds!r}")
    if criterion not in ("F", "likelihood"):
        raise ValueError(f"criterion: must be 'F' or 'likelihood', got {criterion!r}")
    mask = check_mask(mdp, base_mask, "base_mask").copy()
    available = candidates.feasible.copy()
    chosen, history, gains = [], [], []
    for _ in range(rounds):
        idx = np.flatnonzero(available)
        log_f, gain = np.full(len(candidates), np.nan), np.full(len(candidates), -np.inf)
        log_f[idx], gain[idx] = rank_candidates(mdp, demos, candidates.forbidden[:, :, idx], mask)
        if not np.isfinite(gain).any():
            break
        score = np.where(np.isfinite(gain), -log_f if criterion == "F" else gain, -np.inf)
        best = int(np.argmax(score))
        if min_gain is not None and -log_f[best] < min_gain:
            break
        chosen.append(best)
        history.append(log_f)
        gains.append(gain)
        mask &= ~candidates.forbidden[:, :, best]
        available[best] = False
    return InferenceResult(chosen, history, gains, mask)


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
