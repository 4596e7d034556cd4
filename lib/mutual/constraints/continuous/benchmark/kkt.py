"""A published peer: constraints from the KKT conditions of locally optimal demonstrations.

Chou, Ozay and Berenson, "Learning constraints from locally-optimal demonstrations under cost
function uncertainty", IEEE Robotics and Automation Letters 5(2), 2020 (arXiv:2001.09336), and
"Learning parametric constraints in high dimensions from demonstrations", CoRL 2019. The idea:
a demonstration xi = (x_0..x_L, u_0..u_{L-1}) that is locally optimal for

    min_xi  c(xi; gamma) = sum_t l(x_t, u_t; gamma) dt + w(x_L; gamma)
    s.t.    x_{t+1} = F(x_t, u_t),  u_min <= u_t <= u_max,  g(x_t; theta) <= 0  (the unknown constraint)

satisfies the KKT conditions with some multipliers nu_t (dynamics), mu_t >= 0 (control limits) and
lambda_t >= 0 (the constraint), lambda_t g(x_t; theta) = 0. Written out, stationarity in x_t gives
the costates backwards, nu_L = grad w + lambda_L grad g(x_L), nu_t = grad_x l dt + A_t' nu_{t+1}
+ lambda_t grad g(x_t), and stationarity in u_t leaves the residual

    r_t = grad_u l dt + B_t' nu_{t+1} + mu_t,        A_t, B_t = dF/dx, dF/du at the recorded (x_t, u_t),

which is LINEAR in the cost weights gamma and the multipliers (:func:`kkt_model` eliminates nu).
On an unstable system (the cart-pole) the backward recursion grows like the falling pole, e^(4.6 t),
and over 5 s swamps every number, so each demonstration is cut into windows, wherever the recursion
has grown by ``GROWTH`` (:func:`window_ends`; on the benchmark the cart-pole three times per
demonstration, a pendulum now and then near upright, the double integrator and the car never),
whose final costates are left free (the KKT conditions of a locally optimal trajectory
hold on each piece with an unknown terminal costate): r = G gamma + C lambda + mu + F nu_free.
The cost is "uncertain" as in the RA-L paper: gamma weighs the terms of the user's system-file
cost (gamma = 1 is the file's own), each within a factor 2 of it (a box of cost parameters; a
free gamma >= 0 lets a cost that the data leave flat, such as a final velocity they all end at,
explain every demonstration, the classic degeneracy of inverse optimal control).

What we implement (:mod:`.kkt_search`): the RA-L paper's "known constraint parameterization" with
suboptimal demonstrations handled by minimising the KKT residual (the papers relax stationarity the
same way), for one bound, disk or box at a time. For a candidate theta, primal feasibility fixes the
tightest region the data allow (for a bound: the recorded extreme; for a disk or box of a given
centre and shape: the largest that holds no recorded state), complementary slackness allows
lambda_t > 0 only at states within ``EPSILON`` of its boundary, and the residual is minimised over
gamma, lambda, mu -- a least-squares problem with bounds, screened with scipy's NNLS over a grid
of centres and shapes and solved for the chosen ones with cvxpy. A constraint is accepted when
it lowers the Bayesian information criterion of the residual (its free multipliers and parameters
counted); rounds repeat with the accepted constraints' multipliers kept.

Assumptions the benchmark breaks on purpose: the demonstrations are locally optimal for a cost of
the stated form (ours come from feedback controllers, noise, random actions, MPPI), the recorded
controls are the optimiser's (ours are averaged over a step, or inferred where not recorded), and
the dynamics are known exactly (they are: the library's systems).
"""

from dataclasses import dataclass

import numpy as np

from ..recordings import align
from ..systems import integrate

#: the costate recursion is cut where it has grown by this factor (module docstring)
GROWTH = 1e3
#: complementary slackness: a multiplier may act at states within this share of the box's width of the boundary
EPSILON = 0.01
#: controls within this share of the control range of a limit may carry its multiplier
SATURATED = 0.01


@dataclass(eq=False)
class KKTModel:
    """The residual r = G gamma + C lambda + saturated * mu + free nu of a set of demonstrations
    (:func:`kkt_model`): ``states`` (N, L+1, n) wrapped, ``controls`` (N, L, m), ``influence``
    (N, L+1, n, L, m): the residual of demonstration d at the steps of its window before s from a
    unit source e_j in the costate at step s, ``cuts`` (N, L+1) the window ends (their costates are
    free; a multiplier there explains nothing), ``G`` (rows, K) the cost terms' columns, ``free``
    (rows, F) the free costates' columns, ``window`` (rows,) each row's window (demonstration and
    piece), ``saturated`` (rows,) +1 / -1 where a control is at its upper / lower limit (a
    multiplier mu >= 0 there), the ``terms`` named, and the ``problem``."""

    states: np.ndarray
    controls: np.ndarray
    influence: np.ndarray
    cuts: np.ndarray
    G: np.ndarray
    free: np.ndarray
    window: np.ndarray
    saturated: np.ndarray
    terms: list
    problem: object

    @property
    def rows(self):
        return self.G.shape[0]

    def column(self, d, s, gradient):
        """The residual column of a multiplier at state s of demonstration d whose constraint has
        ``gradient`` (n,) there: zero outside demonstration d (and zero at a window end)."""
        N, _, _, L, m = self.influence.shape
        col = np.zeros((N, L, m))
        if not self.cuts[d, s]:
            col[d] = np.einsum("j,jtm->tm", gradient, self.influence[d, s])
        return col.ravel()


def step_controls(problem, states, controls):
    """Controls (N, L, m): the recorded ones, or where none was recorded (one control coordinate)
    the control of the continuous range whose one-step prediction lands nearest the next state
    (201 levels)."""
    N, L1, n = states.shape
    out = np.array(controls, dtype=float) if controls is not None else np.full((N, L1 - 1, problem.system.n_controls), np.nan)
    missing = ~np.isfinite(out).all(axis=2)
    if missing.any():
        if problem.system.n_controls != 1:
            raise ValueError("kkt: inferring unrecorded controls needs one control coordinate")
        levels = np.linspace(problem.controls.min(), problem.controls.max(), 201)
        x, nxt = states[:, :-1][missing], states[:, 1:][missing]
        pred = problem.step(np.repeat(x, levels.size, axis=0), np.tile(levels, len(x))[:, None])
        diff = pred.reshape(len(x), levels.size, n) - nxt[:, None]
        for i in np.flatnonzero(problem.grid.periodic):
            period = problem.grid.high[i] - problem.grid.low[i]
            diff[..., i] = np.mod(diff[..., i] + period / 2, period) - period / 2
        scale = problem.grid.high - problem.grid.low
        out[missing] = levels[np.argmin(((diff / scale) ** 2).sum(axis=2), axis=1)][:, None]
    return out


def jacobians(problem, states, controls):
    """A (N, L, n, n) and B (N, L, n, m) of the one-step map F (RK4 over dt) at the recorded steps,
    by central differences."""
    N, L, m = controls.shape
    n = states.shape[2]
    x, u = states[:, :-1].reshape(-1, n), controls.reshape(-1, m)
    scale = np.r_[problem.grid.high - problem.grid.low, np.ptp(problem.controls, axis=0)]
    h = 1e-6 * np.where(scale > 0, scale, 1.0)
    step = lambda xs, us: integrate(problem.system, xs, us, problem.dt, problem.substeps)
    cols = []
    for k in range(n + m):
        dx, du = np.zeros(n), np.zeros(m)
        (dx if k < n else du)[k if k < n else k - n] = h[k]
        cols.append((step(x + dx, u + du) - step(x - dx, u - du)) / (2 * h[k]))
    J = np.stack(cols, axis=2).reshape(N, L, n, n + m)
    return J[..., :n], J[..., n:]


def window_ends(A, growth=GROWTH):
    """(N, L+1) booleans: where each demonstration's costate recursion is cut -- going back from the
    end, a cut wherever the product A_t' ... A_{c-1}' since the last cut has grown past ``growth``
    in norm (never at the last state, never leaving a window shorter than 2 steps)."""
    N, L, n, _ = A.shape
    cuts = np.zeros((N, L + 1), dtype=bool)
    M = np.broadcast_to(np.eye(n), (N, n, n)).copy()
    length = np.zeros(N, dtype=int)
    for t in range(L - 1, -1, -1):
        M = np.einsum("dvw,dvu->dwu", A[:, t], M)                  # A_t' M
        length += 1
        cut = (np.linalg.norm(M, axis=(1, 2)) > growth) & (length > 2) & (t > 0)
        cuts[cut, t] = True
        M[cut] = np.eye(n)
        length[cut] = 0
    return cuts


def influence(A, B, cuts):
    """(N, L+1, n, L, m): the residual B_t' psi_{t+1} at the steps t < s of s's window of a unit
    costate source e_j at step s, psi_s = e_j, psi_t = A_t' psi_{t+1} (module docstring), for every
    s and j at once; at a window end c (``cuts`` (N, L+1)) the entry is the influence of the free
    costate nu_c, which absorbs every later source."""
    N, L, n, m = B.shape
    P = np.zeros((N, L + 1, n, n))
    out = np.zeros((N, L + 1, n, L, m))
    for t in range(L - 1, -1, -1):
        P[cuts[:, t + 1]] = 0.0
        P[:, t + 1] = np.eye(n)
        out[:, :, :, t, :] = np.einsum("dsjv,dvm->dsjm", P, B[:, t])
        P = np.einsum("dsjv,dvw->dsjw", P, A[:, t])
    return out


def _cost_terms(problem, states, controls):
    """Per term of the file's cost with a nonzero weight: its name, its state-gradient sources
    (N, L+1, n) and its control gradient (N, L, m), each times its weight (gamma = 1: the file's cost)."""
    rw, grid, dt = problem.reward, problem.grid, problem.dt
    N, L1, n = states.shape
    e = rw.errors(grid, states.reshape(-1, n)).reshape(N, L1, n)
    terms = []
    for i in np.flatnonzero(rw.state_weights):
        src = np.zeros((N, L1, n))
        src[:, 1:-1, i] = 2 * rw.state_weights[i] * e[:, 1:-1, i] * dt
        terms.append((f"{grid.names[i]}^2", src, np.zeros_like(controls)))
    for j in np.flatnonzero(rw.control_weights):
        du = np.zeros_like(controls)
        du[..., j] = 2 * rw.control_weights[j] * controls[..., j] * dt
        terms.append((f"control {j}^2", np.zeros((N, L1, n)), du))
    for i in np.flatnonzero(rw.terminal_weights):
        src = np.zeros((N, L1, n))
        src[:, -1, i] = 2 * rw.terminal_weights[i] * e[:, -1, i]
        terms.append((f"final {grid.names[i]}^2", src, np.zeros_like(controls)))
    return terms


def _saturation(problem, controls):
    """Per residual row: +1 where the control is at its upper limit (its multiplier adds to the
    residual), -1 at the lower limit (subtracts), 0 elsewhere."""
    lo, hi = problem.controls.min(axis=0), problem.controls.max(axis=0)
    band = SATURATED * (hi - lo)
    return (np.where(controls >= hi - band, 1.0, 0.0) - np.where(controls <= lo + band, 1.0, 0.0)).ravel()


def kkt_model(problem, recording, growth=GROWTH):
    """The :class:`KKTModel` of ``recording`` on the system file's ``problem`` (aligned to its dt),
    its costate recursions cut where they grow past ``growth`` (:func:`window_ends`)."""
    states, controls, _ = align(recording, problem.dt)
    states = problem.grid.wrap(states.reshape(-1, states.shape[2])).reshape(states.shape)
    controls = step_controls(problem, states, controls)
    A, B = jacobians(problem, states, controls)
    cuts = window_ends(A, growth)
    R = influence(A, B, cuts)
    terms = _cost_terms(problem, states, controls)
    G = np.stack([(du + np.einsum("dsj,dsjtm->dtm", src * ~cuts[..., None], R)).ravel() for _, src, du in terms],
                 axis=1)
    N, L, m = controls.shape
    free = []
    for d, c in zip(*np.nonzero(cuts)):
        for j in range(states.shape[2]):
            col = np.zeros((N, L, m))
            col[d] = R[d, c, j]
            free.append(col.ravel())
    free = np.stack(free, axis=1) if free else np.zeros((N * L * m, 0))
    piece = np.cumsum(np.c_[np.zeros((N, 1), dtype=bool), cuts[:, 1:L]], axis=1)       # window of step t
    rows_window = np.repeat((np.arange(N)[:, None] * (L + 1) + piece).ravel(), m)
    return KKTModel(states, controls, R, cuts, G, free, rows_window, _saturation(problem, controls),
                    [name for name, _, _ in terms], problem)
