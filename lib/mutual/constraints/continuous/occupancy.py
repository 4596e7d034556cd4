"""The expected features of the point model's futures (:mod:`.pointwise`): Algorithm 1's forward pass on the
cells as points -- the first step exactly from continuous points, then the cells' occupancy, a successor's mass
split over its interpolation's allowed vertices by their share of its Z (:func:`.pointwise.vertex_shares`).
Their difference from the demonstrations' own features is the gradient of the log-likelihood in the reward's
weights (Ziebart's eq. 2.8; :func:`.evidence.log_likelihood_gradient`)."""

import numpy as np

from . import pointwise as pw
from .logspace import log0, logsumexp, probabilities


def _spread(moves, mass, logZ_next, at, norm, n_cells):
    """The cells' occupancy (X,) after the moves carry ``mass`` (P,) to their successors, a successor split
    over its vertices by :func:`.pointwise.vertex_shares`. Only the moves with mass are read: the others add exact
    zeros, so the sums are the same to the last bit (most cells hold no mass in the first steps from the
    demonstrated starts)."""
    if moves.target.shape[1] == 1:
        return np.bincount(moves.target[:, 0], weights=np.where(np.isfinite(at), mass, 0.0), minlength=n_cells)
    moving = np.flatnonzero(mass)
    target = moves.target[moving]
    share = pw.vertex_shares(moves.log_weight[moving], target, logZ_next, at[moving], norm[moving])
    return np.bincount(target.ravel(), weights=(mass[moving, None] * share).ravel(), minlength=n_cells)


def expected_features(model, moves, t0, logZ, regions, weights, successors=None):
    """The expected features (d + m running, then d terminal) of the futures from the points of ``moves`` at
    time ``t0`` to the horizon under ``regions``, summed over the points: Algorithm 1 on the point model (the
    first step exactly from the points, then the cells' occupancy). Their difference from the
    demonstrations' features is the gradient of the log-likelihood in the weights. ``successors``: what
    :func:`.pointwise.log_partition` kept for this ``logZ`` (none or empty: computed here). A move's features do
    not change with time, so its expected visits are summed over the steps and weight its features once."""
    mv, X, T = model.moves, model.points.shape[0], model.horizon
    ok = pw.points_allowed(model, regions)
    cell_ok, n_ok = ok.any(axis=1), ok.sum(axis=1)
    run = mv.features.shape[1]
    total = np.zeros(run + model.terminal_features.shape[2])
    first_norm = pw.successor_norm(moves, cell_ok)     # the first step, from the points
    at = pw.successor_log_values(moves, logZ[t0 + 1], cell_ok, first_norm)
    q = pw.by_owner(moves, np.where(pw.allowed_moves(regions, moves), pw.move_rewards(moves, weights), -np.inf) + at)
    p = probabilities(q, logsumexp(q, axis=1))
    total[:run] += p.reshape(-1) @ moves.features
    D = _spread(moves, p.reshape(-1), logZ[t0 + 1], at, first_norm, X)
    move_reward = np.where(pw.allowed_moves(regions, mv), pw.move_rewards(mv, weights), -np.inf)
    norm = pw.successor_norm(mv, cell_ok)
    visits = np.zeros(mv.features.shape[0])          # each move's expected visits, summed over the steps
    for t in range(t0 + 1, T):
        at = successors[t] if successors else pw.successor_log_values(mv, logZ[t + 1], cell_ok, norm)
        w = (D[:, None] * probabilities(pw.by_owner(mv, move_reward + at), logZ[t] + log0(n_ok))).reshape(-1)
        visits += w
        D = _spread(mv, w, logZ[t + 1], at, norm, X)
    total[:run] += visits @ mv.features
    term = np.where(ok, pw.terminal_rewards(model, weights), -np.inf)
    with np.errstate(invalid="ignore"):
        share = np.exp(term - logZ[T][:, None] - log0(n_ok)[:, None])
    share[~np.isfinite(share)] = 0.0
    total[run:] += np.einsum("x,xm,xmd->d", D, share, model.terminal_features)
    return total
