"""Exploring Section 3.4's conjecture: a Hamilton-Jacobi-Bellman equation with a softmax (exploratory).

Section 3.4 expects the continuous analogue of the soft backup (eqs. 2.19-2.21) to be

    -dV/dt (x, t) = softmax_a [ r(x, a) + grad V . f(x, a) ].

On the barycentric discretization (:mod:`.discretization`) the soft backup is a semi-Lagrangian scheme:
E_{x'} V(x') is V linearly interpolated at the integrated point, so V_t(x) = log sum_a exp(r dt +
V_{t+dt}(x + f dt)). Expanding in dt,

    V_t(x) = V_{t+dt}(x) + log sum_a exp(dt H_a),   H_a = r(x, a) + grad V . f(x, a).

* At a fixed temperature per step, log sum_a exp(dt H_a) = log |A| + dt mean_a H_a + O(dt^2): the
  log-partition grows like (T / dt) log |A| -- the entropy of choosing among |A| actions every step
  -- and what remains, V - (T/dt) log |A|, tends to the HJB equation with the *mean* of the
  Hamiltonians over the actions, not a softmax.
* With the temperature scaled with the step, rewards beta r dt with beta = kappa / dt, the scaled
  value W = V / beta obeys W_t = W_{t+dt} + (dt / kappa) log sum_a exp(kappa H_a): Section 3.4's
  equation with softmax_kappa(q) = (1/kappa) log sum_a exp(kappa q_a).

:func:`convergence` computes both discrete values at a start state as the grid and the step
refine together, beside the two PDEs solved by hj-reachability with a custom Hamiltonian
(:class:`Hamiltonian`; Lax-Friedrichs, ENO/WENO upwinding). No claim: an exploration.
"""

import numpy as np
import pandas as pd

from ..backup import log_partition
from .discretization import discretize, kuhn_weights
from .experiments import with_cells

#: jax forms of the named systems (hj-reachability evaluates the dynamics in jax)
JAX_FORMS = ("double_integrator", "pendulum")


def _jax_dynamics(system):
    import jax.numpy as jnp
    p = system.parameters
    if system.spec == "double_integrator":
        return lambda x, u: jnp.array([x[1], u[0]])
    if system.spec == "pendulum":
        m, l, b, g = (p.get(k, d) for k, d in (("mass", 1.0), ("length", 1.0), ("damping", 0.1), ("gravity", 9.81)))
        return lambda x, u: jnp.array([x[1], (u[0] - b * x[1] - m * g * l * jnp.sin(x[0])) / (m * l ** 2)])
    raise ValueError(f"soft HJB: the PDE comparison knows the jax form of {', '.join(JAX_FORMS)} only, "
                     f"not {system.spec!r}")


class _Hamiltonian:
    """Mixin body of :func:`Hamiltonian` (hj-reachability's ``Dynamics`` is imported lazily)."""

    def __init__(self, problem, kappa, mode):
        import hj_reachability as hj
        import jax.numpy as jnp
        self.f, self.kappa, self.mode = _jax_dynamics(problem.system), kappa, mode
        self.controls = jnp.asarray(problem.controls)
        r = problem.reward
        self.goal, self.q, self.c = (jnp.asarray(v) for v in (r.goal, r.state_weights, r.control_weights))
        self.period = jnp.asarray(np.where(problem.grid.periodic, problem.grid.high - problem.grid.low, 0.0))
        lo, hi = problem.controls.min(axis=0), problem.controls.max(axis=0)
        zero = jnp.zeros(1)
        super().__init__("max", "min", hj.sets.Box(jnp.asarray(lo), jnp.asarray(hi)), hj.sets.Box(zero, zero))

    def rate(self, x, u):
        import jax.numpy as jnp
        e = x - self.goal
        e = jnp.where(self.period > 0, -(jnp.mod(-e + self.period / 2, jnp.where(self.period > 0, self.period, 1.0))
                                         - self.period / 2), e)
        return -(e ** 2 @ self.q + u ** 2 @ self.c)

    def __call__(self, state, control, disturbance, time):
        return self.f(state, control)

    def optimal_control_and_disturbance(self, state, time, grad_value):
        return self.controls[0], np.zeros(1)

    def hamiltonian(self, state, time, value, grad_value):
        import jax
        q = jax.vmap(lambda u: self.rate(state, u) + grad_value @ self.f(state, u))(self.controls)
        if self.mode == "mean":
            return q.mean()
        return jax.scipy.special.logsumexp(self.kappa * q) / self.kappa

    def partial_max_magnitudes(self, state, time, value, grad_value_box):
        import jax
        import jax.numpy as jnp
        return jnp.abs(jax.vmap(lambda u: self.f(state, u))(self.controls)).max(axis=0)


def Hamiltonian(problem, kappa=1.0, mode="soft"):
    """hj-reachability dynamics whose Hamiltonian is softmax_kappa (``mode="soft"``) or the mean
    (``"mean"``) over the control set of r(x, u) + p . f(x, u); Lax-Friedrichs dissipation from
    max_u |f_i(x, u)|."""
    import hj_reachability as hj
    cls = type("SoftHamiltonian", (_Hamiltonian, hj.Dynamics), {})
    return cls(problem, kappa, mode)


def pde_value(problem, start, cells, kappa=1.0, mode="soft", accuracy="high"):
    """The PDE's value at ``start`` with T dt to go (terminal value w), on an hj-reachability grid of
    ``cells`` nodes per coordinate over the problem's box."""
    import hj_reachability as hj
    import jax.numpy as jnp
    g = problem.grid
    periodic = tuple(int(i) for i in np.flatnonzero(g.periodic))
    grid = hj.Grid.from_lattice_parameters_and_boundary_conditions(
        hj.sets.Box(jnp.asarray(g.low), jnp.asarray(g.high)), tuple([int(cells)] * g.ndim), periodic_dims=periodic)
    states = np.asarray(grid.states).reshape(-1, g.ndim)
    terminal = jnp.asarray(problem.reward.terminal(g, states).reshape(grid.shape))
    settings = hj.SolverSettings.with_accuracy(accuracy)
    values = hj.solve(settings, Hamiltonian(problem, kappa, mode), grid,
                      jnp.array([0.0, -problem.horizon * problem.dt]), terminal, progress_bar=False)
    return float(grid.interpolate(values[-1], jnp.asarray(start)))


def discrete_values(problem, start, kappa=1.0):
    """At ``start`` (interpolated as the scheme interpolates): the barycentric MDP's log-partition V_0
    at temperature 1 per step, V_0 minus T log |A|, and the scaled value V_0 / beta with
    beta = kappa / dt (module docstring)."""
    p = problem.replace(scheme="barycentric")
    S = discretize(p, scheduler="inline")
    vertices, weights = kuhn_weights(p.grid, np.atleast_2d(start))      # V at start: the scheme's interpolation
    mask = np.ones((p.grid.n_cells, p.n_actions), dtype=bool)
    fixed = p.replace(reward=_tempered(p.reward, 1.0))
    scaled = p.replace(reward=_tempered(p.reward, p.dt / kappa))
    v_fixed = float(weights[0] @ log_partition(fixed.mdp(S), mask)[vertices[0], 0])
    v_scaled = float(weights[0] @ log_partition(scaled.mdp(S), mask)[vertices[0], 0]) * p.dt / kappa
    return {"V0": v_fixed, "V0 - T log|A|": v_fixed - p.horizon * np.log(p.n_actions), "V0 / beta": v_scaled}


def _tempered(reward, temperature):
    from dataclasses import replace
    return replace(reward, temperature=float(temperature))


def convergence(problem, start, resolutions, courant=0.5, kappa=1.0, pde_cells=101, accuracy="high"):
    """Discrete values at ``start`` as the grid refines, each with dt = ``courant`` x min over the
    coordinates of (cell width / largest speed), and the horizon kept at the problem's duration; beside the mean- and
    soft-Hamiltonian PDE values on ``pde_cells`` nodes per coordinate (hj-reachability's ``accuracy``).
    Returns a DataFrame."""
    duration = problem.horizon * problem.dt
    speed = _max_speeds(problem)
    rows = []
    for cells in resolutions:
        p = with_cells(problem, cells)
        step = courant * min(np.diff(e).min() / max(v, 1e-12) for e, v in zip(p.grid.edges, speed))
        steps = max(1, int(np.ceil(duration / step)))
        p = p.replace(dt=duration / steps, horizon=steps)
        rows.append({"cells per coordinate": cells, "dt": p.dt, "steps T": steps, **discrete_values(p, start, kappa)})
    table = pd.DataFrame(rows)
    table["PDE, mean Hamiltonian"] = pde_value(problem, start, pde_cells, kappa, "mean", accuracy)
    table["PDE, softmax Hamiltonian"] = pde_value(problem, start, pde_cells, kappa, "soft", accuracy)
    return table


def _max_speeds(problem):
    """max |f_i(x, u)| over the cell centres and controls, per coordinate."""
    centres = problem.grid.centers()
    X, A = len(centres), problem.n_actions
    return np.abs(problem.system.f(np.repeat(centres, A, axis=0), np.tile(problem.controls, (X, 1)))).max(axis=0)
