"""Learn: the robot infers a simulated human's chance constraints from demonstrations (chapters
2-3), with a stopping rule, from one task or from several tasks pooled (Fig. 3.3's caption).

The human's constraints are a :class:`ConstraintSet` (cells with chance thresholds, eq. 3.1, and
forbidden actions). Inference is greedy maximum likelihood (Sec. 2.4) over the single-constraint
candidates of :func:`mutual.constraints.inference.constraint_candidates` (each cell at its data-allowed
threshold psi*, eq. 3.3), ranked by the demonstrations' exact log-likelihood gain (the
``criterion="likelihood"`` of :func:`mutual.constraints.inference.greedy_inference`), summed over
tasks. The stopping rule is a likelihood-ratio test: a candidate is added only while its total
log-likelihood gain is at least half the ``level`` quantile of chi-square with one degree of freedom
(1.92 nats at 95%), so the bar on the gain per demonstration falls as 1/N.
"""

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import stats

from ..constraints import (Demonstrations, as_tasks, check_mask, constraint_candidates, constraint_mask,
                           sample_demonstrations, score_candidates, soft_policy)
from .outcomes import policy_outcomes


@dataclass(frozen=True)
class ConstraintSet:
    """A demonstrator's constraints: chance constraints on ``states`` with thresholds ``psi``
    (eq. 3.1; one value or one per state) and forbidden ``actions`` (eq. 2.11)."""

    states: tuple = ()
    psi: object = 0.0
    actions: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "states", tuple(int(s) for s in np.atleast_1d(self.states)))
        object.__setattr__(self, "actions", tuple(int(a) for a in np.atleast_1d(self.actions)))
        psi = np.broadcast_to(np.asarray(self.psi, dtype=float).ravel(), (len(self.states),))
        if np.any(np.isnan(psi)) or np.any(psi < 0) or np.any(psi > 1):
            raise ValueError(f"psi: thresholds must lie in [0, 1], got {self.psi!r}")
        object.__setattr__(self, "psi", tuple(float(p) for p in psi))

    @property
    def labels(self):
        """("state", x) and ("action", a) pairs, in the order states then actions."""
        return [("state", s) for s in self.states] + [("action", a) for a in self.actions]

    def mask(self, mdp):
        """The allowed-action mask Phi_C (X, A) of eq. (3.2)."""
        return constraint_mask(mdp, list(self.states), list(self.psi) or 0.0, list(self.actions))

    def without(self, label):
        """The same set without one constraint ``("state", x)`` or ``("action", a)``."""
        kind, index = label
        keep = [i for i, s in enumerate(self.states) if not (kind == "state" and s == index)]
        return ConstraintSet(tuple(self.states[i] for i in keep), tuple(self.psi[i] for i in keep),
                             tuple(a for a in self.actions if not (kind == "action" and a == index)))

    def only(self, label):
        """The set holding just the constraint ``label``."""
        kind, index = label
        if kind == "state":
            return ConstraintSet((index,), self.psi[self.states.index(index)], ())
        return ConstraintSet((), 0.0, (index,))


def relevance(mdp, truth):
    """For each true constraint, the probability that the demonstrator obeying all the *other*
    true constraints (eq. 2.19) breaks it at least once in a task: exact forward passes
    (:func:`mutual.cycle.outcomes.policy_outcomes`). Returns ``{label: probability}``."""
    return {label: policy_outcomes(mdp, soft_policy(mdp, truth.without(label).mask(mdp)),
                                   allowed=truth.only(label).mask(mdp))["p_break"]
            for label in truth.labels}


def stop_threshold(level=0.95):
    """Half the ``level`` quantile of chi-square(1): the least total log-likelihood gain (nats) for
    which a likelihood-ratio test at that level accepts one more constraint."""
    if not 0 < level < 1:
        raise ValueError(f"level: must lie in (0, 1), got {level!r}")
    return 0.5 * float(stats.chi2.ppf(level, 1))


def concatenate(demos_list):
    """Pool demonstration sets of the same length into one :class:`Demonstrations`."""
    if not demos_list or len({d.steps for d in demos_list}) != 1:
        raise ValueError("demos_list: need one or more demonstration sets of the same length")
    return Demonstrations(np.concatenate([d.states for d in demos_list]),
                          np.concatenate([d.actions for d in demos_list]))


@dataclass(frozen=True, eq=False)
class PooledInference:
    """Greedy inference over pooled tasks: ``chosen`` candidate numbers in order, ``total_gain``
    the exact log-likelihood gain (nats, all demonstrations) of each, ``mask`` the final Phi_C,
    ``candidates`` the candidate set, ``stopped`` whether the stopping rule (not the round cap) ended it."""

    chosen: list
    total_gain: np.ndarray
    mask: np.ndarray
    candidates: object
    stopped: bool

    @property
    def labels(self):
        return [(str(self.candidates.kind[k]), int(self.candidates.index[k])) for k in self.chosen]


def pooled_inference(tasks, max_rounds=10, level=0.95, candidates=None):
    """Greedy maximum-likelihood inference from demonstrations of several tasks in one world.

    ``tasks``: (mdp, demos) pairs that share the dynamics S (same world, other start, goal or
    reward; :func:`mutual.constraints.candidates.as_tasks` checks them). Candidates come from all
    demonstrations pooled (psi* over every demonstrated transition, eq. 3.3). Each round adds the
    candidate with the largest total exact log-likelihood gain sum_k N_k gain_k (the library's pooled
    :func:`mutual.constraints.inference.score_candidates`), until the gain falls below
    :func:`stop_threshold` (``level``; None: no stopping rule) or ``max_rounds`` are done.
    """
    if not tasks:
        raise ValueError("tasks: need at least one (mdp, demos) pair")
    if isinstance(max_rounds, bool) or not isinstance(max_rounds, (int, np.integer)) or max_rounds < 0:
        raise ValueError(f"max_rounds: must be a non-negative integer, got {max_rounds!r}")
    tasks = as_tasks([m for m, _ in tasks], [d for _, d in tasks])
    if candidates is None:
        candidates = constraint_candidates([m for m, _ in tasks], [d for _, d in tasks])
    threshold = -np.inf if level is None else stop_threshold(level)
    n_total = sum(d.n for _, d in tasks)
    first = tasks[0][0]
    mask = np.ones((first.n_states, first.n_actions), dtype=bool)
    available = candidates.feasible.copy()
    chosen, gains, stopped = [], [], False
    for _ in range(max_rounds):
        idx = np.flatnonzero(available)
        if idx.size == 0:
            break
        total = n_total * score_candidates(tasks, candidates, idx, mask)[1]
        j = int(np.argmax(total))
        if not np.isfinite(total[j]) or total[j] < threshold:
            stopped = True
            break
        chosen.append(int(idx[j]))
        gains.append(float(total[j]))
        mask &= ~candidates.forbidden_matrix[:, idx[j]].toarray().reshape(mask.shape)
        available[idx[j]] = False
    return PooledInference(chosen, np.array(gains), mask, candidates, stopped)


def per_demo_log_likelihood(mdp, demos, mask=None):
    """sum_t log P_C(a_t | x_t, t) of each demonstration (eq. 2.19), (N,); -inf where infeasible."""
    pi = soft_policy(mdp, check_mask(mdp, mask))
    t = np.broadcast_to(np.arange(demos.steps), demos.actions.shape)
    with np.errstate(divide="ignore"):
        return np.log(pi[t, demos.states[:, :-1], demos.actions]).sum(axis=1)


def scores(labels, truth, relevant):
    """Precision of the inferred constraints ``labels`` against all of ``truth`` (a true constraint
    outside the task's relevant set is still correct), recall of the ``relevant`` ones and of all."""
    inferred, true, rel = set(labels), set(truth.labels), set(relevant)
    hits = inferred & true
    return {"n_inferred": len(inferred), "precision": len(hits) / len(inferred) if inferred else np.nan,
            "recall_relevant": len(inferred & rel) / len(rel) if rel else np.nan,
            "recall_all": len(hits) / len(true) if true else np.nan}


def sample_efficiency(mdp, truth, n_values, seeds, relevant, max_rounds=10, level=0.95, n_heldout=200):
    """How inference improves with the number of demonstrations N (simulated demonstrator, eq. 2.19).

    For each seed, ``max(n_values)`` demonstrations are drawn from the true constrained Boltzmann
    policy (plus ``n_heldout`` fresh ones from a separate stream) and inference with the stopping rule
    (:func:`pooled_inference`) runs on the first N of them for every N in ``n_values`` (nested sets).
    One row per (seed, N): the :func:`scores` against ``truth`` and its ``relevant`` labels, the
    inferred labels, the training demonstrations' exact log-likelihood per demonstration under the
    inferred constraints, the truth and no constraints, and on the held-out demonstrations the share
    that the inferred constraints allow and their mean log-likelihood under inferred and true sets.
    """
    n_values = sorted(int(n) for n in n_values)
    if not n_values or n_values[0] < 1:
        raise ValueError(f"n_values: need positive numbers of demonstrations, got {n_values!r}")
    true_mask = truth.mask(mdp)
    rows = []
    for seed in seeds:
        demos = sample_demonstrations(mdp, n_values[-1], true_mask, rng=np.random.default_rng([seed, 0]))
        heldout = sample_demonstrations(mdp, n_heldout, true_mask, rng=np.random.default_rng([seed, 1]))
        held_true = per_demo_log_likelihood(mdp, heldout, true_mask)
        for n in n_values:
            part = Demonstrations(demos.states[:n], demos.actions[:n])
            run = pooled_inference([(mdp, part)], max_rounds, level)
            held = per_demo_log_likelihood(mdp, heldout, run.mask)
            ok = np.isfinite(held)
            rows.append({"seed": seed, "n_demos": n, **scores(run.labels, truth, relevant),
                         "inferred": run.labels, "stopped_by_rule": run.stopped,
                         "loglik_inferred": per_demo_log_likelihood(mdp, part, run.mask).mean(),
                         "loglik_truth": per_demo_log_likelihood(mdp, part, true_mask).mean(),
                         "loglik_none": per_demo_log_likelihood(mdp, part, None).mean(),
                         "heldout_allowed": ok.mean(),
                         "heldout_loglik_inferred": held[ok].mean() if ok.any() else np.nan,
                         "heldout_loglik_truth": held_true[ok].mean() if ok.any() else np.nan})
    return pd.DataFrame(rows)
