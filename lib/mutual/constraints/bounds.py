"""A cheap upper bound on every candidate's gain -log F (eq. 2.25), so that greedy inference can
skip candidates that cannot win a round and still make exactly the choices of scoring them all.

Write u_t(x) = -log F_{C+,t}(x) >= 0 and, at a state x where C+ newly forbids some actions,
p_t(x) = P_{C0}(allowed by C+ | x, t) and c_t(x) = -log p_t(x) (0 where C+ forbids nothing).
Theorem 2.3.1's recursion gives, with pi' the C0 policy conditioned on the actions C+ allows,

    u_t(x) = c_t(x) - log E_{a ~ pi'} exp(-E_{x'} u_{t+1}(x'))
          <= c_t(x) + E_{a ~ pi'} E_{x'} u_{t+1}(x')            (Jensen: -log E e^-Y <= E Y),

so u_0(x_0) <= E_{pi'}[sum_t c_t(x_t)]. pi' equals the C0 policy until the trajectory first
enters the set R of states where C+ forbids something, hence

    -log F_{C+,0}(x_0) <= P_{C0}(enter R before T) * T * max_{t, x in R} c_t(x)
                       <= N_{C0}(R) * T * max_{t, x in R} c_t(x),

with N_{C0}(R) the C0 agent's expected number of visits to R in steps 0..T-1 (one forward pass
for all candidates). The bound is 0 when R is never visited (then F = 1 exactly) and infinite
when C+ leaves some state of R without an allowed action.
"""

import numpy as np
import scipy.sparse as sp

from .mdp import check_mask, soft_policy

SAFETY = 1e-9   # relative and absolute slack for rounding in the forward pass


def expected_visits(mdp, mask, starts):
    """(pi, N): the C0 policy P_C0(a | x, t) (T, X, A) and the expected number of visits N(x) in
    steps 0..T-1 of an agent that starts at the empirical distribution of ``starts``."""
    pi = soft_policy(mdp, mask)
    D = np.bincount(np.asarray(starts), minlength=mdp.n_states) / len(starts)
    N = np.zeros(mdp.n_states)
    ST = mdp.transitions.T
    for t in range(mdp.horizon):
        N += D
        D = np.asarray(ST @ (D[:, None] * pi[t]).ravel())
    return pi, N


def gain_bounds(mdp, demos, mask, forbidden):
    """Upper bounds (K,) on the mean over ``demos`` of -log F_{C+,0}(x_0) for the candidates
    C+ = C0 + ``forbidden`` (sparse (X*A, K)) given the current constraints Phi_C0 = ``mask``
    (module docstring). Never below the exact value."""
    X, A, T = mdp.n_states, mdp.n_actions, mdp.horizon
    mask = check_mask(mdp, mask, "mask")
    pi, N = expected_visits(mdp, mask, demos.states[:, 0])
    coo = sp.coo_matrix(forbidden)
    newly = mask.ravel()[coo.row] & coo.data.astype(bool)
    rows, k = coo.row[newly], coo.col[newly]
    K = forbidden.shape[1]
    if rows.size == 0:
        return np.zeros(K)
    groups, g = np.unique(k.astype(np.int64) * X + rows // A, return_inverse=True)
    gx, gk = groups % X, groups // X
    cut = np.zeros((groups.size, A), dtype=bool)                     # actions C+ newly forbids at x
    cut[g, rows % A] = True
    keep = mask[gx] & ~cut                                           # actions still allowed at x
    c = np.empty(groups.size)
    for chunk in range(0, groups.size, 4096):
        part = slice(chunk, chunk + 4096)
        # p_t(x) summed over the kept actions directly (no 1 - mass cancellation), 0 when none is kept
        rows_pi = pi[:, gx[part], :]
        p = np.einsum("tga,ga->gt", rows_pi, keep[part])
        alive = rows_pi.sum(axis=2).T > 0.5          # C0 itself leaves x no action at other times:
        with np.errstate(divide="ignore"):           # neither agent is ever there then
            c[part] = np.where(alive, -np.log(np.where(alive, p, 1.0)), 0.0).max(axis=1)
    visits = np.bincount(gk, weights=N[gx], minlength=K)
    worst = np.zeros(K)
    np.maximum.at(worst, gk, c)
    with np.errstate(invalid="ignore"):
        bound = np.where(visits > 0, visits * T * worst, 0.0)
    return bound * (1 + SAFETY) + SAFETY
