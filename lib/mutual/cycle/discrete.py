"""The discrete loop's studies (gridworld, chapters 2-3 and 6): act with learned constraints in a new
task, pool a second task's demonstrations into the blind spot, and show the constraints to an observer.

Every probability here is computed exactly by forward passes (:mod:`mutual.cycle.outcomes`,
:mod:`mutual.cycle.observer`) except the distribution of the observer's time to confidence, which is
a first-passage time of the log-odds and is counted on sampled rollouts.
"""

import numpy as np
import pandas as pd
from scipy import stats
from scipy.special import expit, logit

from ..constraints import sample_demonstrations, soft_policy
from .learning import pooled_inference, scores
from .mdp_legibility import legibility_weights, legible_backup
from .observer import expected_log_odds, log_odds_paths, step_log_ratio, time_to_confidence
from .outcomes import policy_outcomes, sample_rollouts


def compare_robots(mdp, truth, masks):
    """Each robot ``{name: Phi_C (X, A) or None}`` acts by its constrained Boltzmann policy (eq. 2.19) in
    ``mdp``; exact probabilities of breaking the ``truth`` (a ConstraintSet), of entering one of its
    cells, of either, and the expected task reward (eq. 2.3), one row per robot."""
    allowed = truth.mask(mdp)
    rows = []
    for name, mask in masks.items():
        out = policy_outcomes(mdp, soft_policy(mdp, mask), allowed=allowed, forbidden_states=truth.states)
        rows.append({"robot": name, **{k: out[k] for k in ("p_break", "p_enter", "p_either", "expected_reward")}})
    return pd.DataFrame(rows)


def blind_spot_study(first, second, truth, n_demos, seeds, relevant, max_rounds=10, level=0.95):
    """Inference from the first task's demonstrations alone and pooled with the second task's (same
    world, other start and goal), for each seed: the inferred labels and :func:`scores` against the
    second task's ``relevant`` constraints. ``first``/``second`` are MDPs; ``n_demos`` per task."""
    rows = []
    for seed in seeds:
        d1 = sample_demonstrations(first, n_demos, truth.mask(first), rng=np.random.default_rng([seed, 10]))
        d2 = sample_demonstrations(second, n_demos, truth.mask(second), rng=np.random.default_rng([seed, 20]))
        for name, tasks in (("first task", [(first, d1)]), ("pooled", [(first, d1), (second, d2)])):
            run = pooled_inference(tasks, max_rounds, level)
            rows.append({"seed": seed, "demonstrations": name, **scores(run.labels, truth, relevant),
                         "inferred": run.labels})
    return pd.DataFrame(rows)


def legible_robots(mdp, robot_mask, alpha, kind="anticipatory", soft=True):
    """The plain robot (P_C of the robot's constraints, or the reward-optimal robot within them when
    ``soft=False``) and the legible robot of :mod:`mutual.cycle.mdp_legibility` for the observer's
    test as the robot models it (H1 = its own constraints, H0 = none). Returns {name: policy}."""
    ratio = step_log_ratio(mdp, robot_mask)
    w = legibility_weights(mdp.horizon, kind)
    plain = soft_policy(mdp, robot_mask) if soft else legible_backup(mdp, robot_mask, ratio, alpha, 0 * w, soft=False)[1]
    return {"plain": plain, "legible": legible_backup(mdp, robot_mask, ratio, alpha, w, soft=soft)[1]}


def observer_study(mdp, policies, observer_mask, n_observers, episodes, rng, level=0.95, prior=0.5):
    """The observer (H1: ``observer_mask``, H0: no constraints) watching each robot ``{name: policy}``
    repeat the task ``episodes`` times, its log-odds carried over from one episode to the next.

    Returns ``(summary, curves)``. ``summary``: per robot the exact expected log-odds at the end of one
    episode, the probability that H1 is refuted in an episode (a forbidden action seen), and, from
    ``n_observers`` sampled observers, the share reaching P(H1) >= ``level`` within each episode with a
    Clopper-Pearson 95% interval and the median number of steps to get there (inf when fewer than half
    do). ``curves``: per robot the exact mean log-odds (T+1,) of one episode, the sampled mean
    posterior (episodes T + 1,) and the times to confidence (n_observers,), nan where never reached.
    """
    ratio = step_log_ratio(mdp, observer_mask)
    T = mdp.horizon
    rows, curves = [], {}
    for name, policy in policies.items():
        mean, refuted = expected_log_odds(mdp, policy, ratio, prior)
        rolls = sample_rollouts(mdp, policy, n_observers * episodes, rng)
        start = logit(prior)
        with np.errstate(invalid="ignore"):
            gained = (log_odds_paths(ratio, rolls, prior) - start).reshape(n_observers, episodes, T + 1)
            offset = np.concatenate([np.zeros((n_observers, 1)), np.cumsum(gained[:, :-1, -1], axis=1)], axis=1)
            path = start + np.concatenate([np.zeros((n_observers, 1)),
                                           (gained[:, :, 1:] + offset[:, :, None]).reshape(n_observers, -1)], axis=1)
        posterior = expit(path)
        first = time_to_confidence(posterior, level)
        row = {"robot": name, "expected_log_odds_end": mean[-1], "p_refuted_per_episode": refuted[-1]}
        for k in range(1, episodes + 1):
            hits = int(np.sum(first <= k * T))
            ci = stats.binomtest(hits, n_observers).proportion_ci(0.95)
            row.update({f"p_confident_ep{k}": hits / n_observers, f"p_confident_ep{k}_low": ci.low,
                        f"p_confident_ep{k}_high": ci.high})
        row["median_steps_to_confidence"] = float(np.median(np.where(np.isnan(first), np.inf, first)))
        rows.append(row)
        curves[name] = {"expected_log_odds": mean, "mean_posterior": posterior.mean(axis=0), "time": first}
    return pd.DataFrame(rows), curves


def alpha_sweep(mdp, robot_mask, observer_mask, alphas, kind="anticipatory", prior=0.5):
    """Exact trade-off of the legible robot (soft) as ``alpha`` varies: its anticipatory legibility
    (mean over time of the observer's expected log-odds), expected log-odds after T/4 and T/2 steps,
    expected reward and probability of breaking the observer's constraints; ``alpha = inf`` is the plain robot."""
    observer = step_log_ratio(mdp, observer_mask)
    ratio = step_log_ratio(mdp, robot_mask)
    w = legibility_weights(mdp.horizon, kind)
    rows = []
    for alpha in alphas:
        policy = (soft_policy(mdp, robot_mask) if np.isinf(alpha)
                  else legible_backup(mdp, robot_mask, ratio, alpha, w)[1])
        mean, _ = expected_log_odds(mdp, policy, observer, prior)
        out = policy_outcomes(mdp, policy, allowed=observer_mask)
        rows.append({"alpha": alpha, "mean_log_odds_over_time": float(mean[1:].mean()),
                     "log_odds_quarter": float(mean[mdp.horizon // 4]), "log_odds_half": float(mean[mdp.horizon // 2]),
                     "expected_reward": out["expected_reward"], "p_break": out["p_break"]})
    return pd.DataFrame(rows)
