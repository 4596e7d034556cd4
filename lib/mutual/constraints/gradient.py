"""Ziebart's gradient (eq. 2.8, Algorithm 1) checked against finite differences of the likelihood.

With a reward linear in features, r_theta(x, a) = theta . phi(x, a) (eqs. 2.4, 2.6-2.7), the
log-likelihood of a demonstration under the maximum-entropy distribution has the gradient
f(xi) - E f: its feature counts minus their expectation, which Algorithm 1's backward-forward
pass computes (:func:`mutual.constraints.backup.expected_features`). Eq. (2.8) prints the sum of
the demonstrations' counts minus *one* expectation; per demonstration (Ziebart's eq. 5, which the
thesis follows) the two sides match, summed over |D| demonstrations the expectation counts |D|
times. :func:`gradient_check` compares the per-demonstration form with central differences of the
exact log-likelihood (eq. 2.19, :func:`~mutual.constraints.demonstrations.demonstration_log_likelihood`);
:func:`printed_gradient_check` compares the printed form with the differences of the likelihood of all of D.
"""

from dataclasses import replace

import numpy as np

from .backup import expected_features
from .demonstrations import check_demonstrations, demonstration_log_likelihood


def _features(mdp, features):
    phi = np.asarray(features, dtype=float)
    if phi.ndim == 2 and phi.shape[0] == mdp.n_states:
        phi = np.repeat(phi[:, None, :], mdp.n_actions, axis=1)
    if phi.ndim != 3 or phi.shape[:2] != (mdp.n_states, mdp.n_actions) or not np.all(np.isfinite(phi)):
        raise ValueError(f"features: must be finite (X, A, n) or (X, n) with (X, A) = {(mdp.n_states, mdp.n_actions)}, "
                         f"got shape {phi.shape}")
    return phi


def _theta(theta, n):
    th = np.asarray(theta, dtype=float).reshape(-1)
    if th.size != n or not np.all(np.isfinite(th)):
        raise ValueError(f"theta: must be {n} finite weights (one per feature), got {theta!r}")
    return th


def reward_model(mdp, features, theta):
    """``mdp`` with the running reward theta . phi(x, a) (eq. 2.4); the terminal reward w is kept (eq. 2.6)."""
    phi = _features(mdp, features)
    return replace(mdp, reward=phi @ _theta(theta, phi.shape[2]))


def mean_log_likelihood(mdp, features, theta, demos, mask=None):
    """The demonstrations' log-likelihood per demonstration under reward theta . phi (eq. 2.19)."""
    return demonstration_log_likelihood(reward_model(mdp, features, theta), demos, mask) / demos.n


def feature_gradient(mdp, features, theta, demos, mask=None):
    """Eq. (2.8) per demonstration: the mean feature counts f(xi) of ``demos`` minus their expectation under
    the theta-reward policy from ``mdp.initial`` (Algorithm 1)."""
    check_demonstrations(mdp, demos)
    phi = _features(mdp, features)
    counts = phi[demos.states[:, :-1], demos.actions].sum(axis=1).mean(axis=0)
    return counts - expected_features(reward_model(mdp, phi, theta), phi, mask)


def gradient_check(mdp, features, theta, demos, mask=None, step=1e-5):
    """Eq. (2.8) against central differences of :func:`mean_log_likelihood`: ``(analytic, numeric, max |gap|)``."""
    phi = _features(mdp, features)
    th = _theta(theta, phi.shape[2])
    numeric = np.empty(th.size)
    for i in range(th.size):
        e = np.zeros(th.size)
        e[i] = step
        numeric[i] = (mean_log_likelihood(mdp, phi, th + e, demos, mask)
                      - mean_log_likelihood(mdp, phi, th - e, demos, mask)) / (2 * step)
    analytic = feature_gradient(mdp, phi, th, demos, mask)
    return analytic, numeric, float(np.max(np.abs(analytic - numeric)))


def printed_gradient_check(mdp, features, theta, demos, mask=None, step=1e-5):
    """Eq. (2.8) as printed, sum over D of f(xi) minus one expectation E f, against central differences of the
    log-likelihood of all of D (|D| times :func:`mean_log_likelihood`): ``(printed, numeric, max |gap|)``. The
    gap is (|D| - 1) E f when the per-demonstration form holds."""
    analytic, numeric, _ = gradient_check(mdp, features, theta, demos, mask, step)
    expected = expected_features(reward_model(mdp, features, theta), _features(mdp, features), mask)
    printed = demos.n * (analytic + expected) - expected
    return printed, demos.n * numeric, float(np.max(np.abs(printed - demos.n * numeric)))
