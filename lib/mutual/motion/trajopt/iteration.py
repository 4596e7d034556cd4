"""One iLQR iteration as a pure function of the solver's state: the model and backward pass, the
line search, the regularisation schedule and the convergence tests (Tassa, Erez & Todorov 2012,
section II-F; Todorov & Li 2005).

**Scale-free tests.** ``M``, the magnitude of the objective (the sum of the absolute stage and
terminal costs), is the scale the cost is known to (its rounding error is ``~eps M``); ``c``, the
largest control curvature of the model, is the scale of the regularisation ``mu``. Both scale
with the objective, so every test below is unchanged when the objective is multiplied by a
constant, and the Newton decrement is also unchanged by a linear change of the controls:

* *relative gradient*: converged when the predicted decrease ``1/2 g'H^-1 g <= grad_tol^2 M``
  (``g`` the gradient in the controls, ``H`` the model's (regularised) Hessian);
* *relative decrease and step*: converged when an accepted step lowered the cost by at most
  ``stall_tol M`` and moved no control by more than ``step_tol`` times the largest control;
* *rounding*: when no step size lowers the cost and the predicted decrease is below
  ``ROUNDING_TOL M``, the point is converged to rounding level (not a failure);
* *divergence*: the cost fell below ``J(u0) - divergence_ratio S``, where ``S`` is the scale of
  the start (``M`` at ``u0``, or the first predicted decrease if larger);
* *regularisation exhausted*: ``mu > reg_max`` (relative to ``c``).

(ZERO) An objective whose optimum costs exactly 0 has no scale of its own (``M -> 0``); there ``M``
is floored at ``eps c``, the cost of changing a control by ``sqrt(eps) ~ 1.5e-8`` of its units.

**Gauss-Newton, DDP, or both.** ``second_order=False`` drops the dynamics' curvature
(Gauss-Newton iLQR: cheap passes, but only linear convergence where that curvature matters, as
for the legible objectives of chapter 7); ``True`` keeps it (DDP: quadratic convergence near a
minimum, but far from it ``Q_uu`` is often indefinite and needs heavy regularisation); ``"auto"``
starts with Gauss-Newton and switches to DDP for good from the first pass whose predicted decrease
is below ``SWITCH_TO_DDP M`` or that follows a Gauss-Newton step the line search had to shorten
(its model proved poor). The choice of rule was measured on the Fig. 7.2 problems and a sweep of
64 legible weights (total passes: Gauss-Newton 1588, DDP 1351, this rule 734).
"""

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from .backward import backward_pass
from .line_search import line_search, no_step
from .model import quadratic_model
from .problem import cost_and_magnitude, rollout

MU_MIN, DELTA0 = 1e-6, 2.0  # Tassa et al. (2012): smallest nonzero mu (relative to c), growth factor of mu
SWITCH_TO_DDP = 1e-3  # second_order="auto": DDP once the predicted decrease is below this fraction of M
ROUNDING_TOL = 1e-9  # a predicted decrease below this fraction of M that no step realises is rounding
EPS = float(np.finfo(float).eps)  # M is floored at EPS c: a cost that is exactly 0 (ZERO)
RUNNING, CONVERGED, NONFINITE_START, INDEFINITE, NO_DECREASE, DIVERGED = range(6)
# the scalars a solve returns, in one array
SUMMARY = ("status", "steps", "passes", "decrease", "magnitude", "step", "mu", "minimum", "start_cost", "scale")


def _where(flag, new, state):
    """``new`` where ``flag`` holds, else the same entries of ``state`` (dicts of arrays)."""
    return {key: jnp.where(flag, value, state[key]) for key, value in new.items()}


def initial(problem, x0, us, params, max_iter):
    """The state of a solve before its first pass (a dict of arrays)."""
    xs = rollout(problem, x0, us, params)
    cost, mag = cost_and_magnitude(problem, xs, us, params)
    n, m, N = xs.shape[1], us.shape[1], us.shape[0]
    count, real = jnp.zeros((), jnp.int32), jnp.zeros(())
    return dict(xs=xs, us=us, G=jnp.zeros((N, m, 1 + n)), cost=cost, mag=mag,
                costs=jnp.full(max_iter + 1, jnp.nan).at[0].set(cost), steps=count, passes=count,
                mu=real, delta=real + 1.0, decrease=real + jnp.nan, step=real + jnp.nan, scale=mag,
                certified=jnp.zeros((), bool), size=real + 1.0, ddp=jnp.zeros((), bool),
                status=jnp.where(jnp.isfinite(cost), RUNNING, NONFINITE_START).astype(jnp.int32))


def is_near(s, second_order):
    """Whether this pass keeps the dynamics' curvature (DDP)."""
    if second_order == "auto":  # Gauss-Newton far from the optimum, DDP close to it
        # DDP from the first pass that is close (small predicted decrease) or that follows a
        # Gauss-Newton step that had to be shortened (its model proved poor), and on
        return s["ddp"] | (s["decrease"] <= SWITCH_TO_DDP * s["mag"]) | (s["size"] < 1)
    return jnp.asarray(bool(second_order))


def regularisation(s, accepted):
    """Tassa et al. (2012), section II-F: a rejected pass raises ``mu`` (and its growth ``delta``),
    an accepted one lowers them; ``mu`` below ``MU_MIN`` snaps to 0. Returns the new ``(mu, delta)``
    and the raised ``mu`` (for the exhaustion test)."""
    delta_up = jnp.maximum(DELTA0, s["delta"] * DELTA0)
    mu_up = jnp.maximum(MU_MIN, s["mu"] * delta_up)
    delta_down = jnp.minimum(1 / DELTA0, s["delta"] / DELTA0)
    mu_down = jnp.where(s["mu"] * delta_down > MU_MIN, s["mu"] * delta_down, 0.0)
    return jnp.where(accepted, mu_down, mu_up), jnp.where(accepted, delta_down, delta_up), mu_up


def stop_status(s, tol, c, pd, stationary, rounding, accepted, mu_up, trial, scale):
    """The convergence and divergence tests (module docstring): the status after this pass."""
    x_new, u_new, c_new, mag_new = trial
    step = jnp.max(jnp.abs(u_new - s["us"]))
    largest = jnp.maximum(jnp.max(jnp.abs(u_new)), jnp.max(jnp.abs(s["us"])))
    stalled = ((s["cost"] - c_new <= tol.stall_tol * jnp.maximum(mag_new, EPS * c))
               & (step <= tol.step_tol * largest))
    runaway = (c_new < s["costs"][0] - tol.divergence_ratio * scale) | ~(
        jnp.maximum(jnp.max(jnp.abs(x_new)), jnp.max(jnp.abs(u_new))) <= tol.divergence_bound)
    status = jnp.select(
        [stationary | rounding,
         ~accepted & (mu_up > tol.reg_max),
         accepted & runaway,
         accepted & (stalled | (c_new <= tol.target))],
        [CONVERGED, jnp.where(pd, NO_DECREASE, INDEFINITE), DIVERGED, CONVERGED], RUNNING)
    return status.astype(jnp.int32), step


def iteration(problem, s, x0, params, tol, second_order, any_near=None):
    """One backward pass, line search and test: the next state of a running solve.
    ``any_near``: whether any member of a batch needs the curvature (computed only then)."""
    near = is_near(s, second_order)
    model = quadratic_model(problem, s["xs"], s["us"], params, bool(second_order),
                            near if any_near is None else any_near)
    G, d1, d2, pd = backward_pass(model, s["mu"], jnp.where(near, 1.0, 0.0))
    decrease = -(d1 + d2)
    mag = jnp.maximum(s["mag"], EPS * model.c)  # a cost that is exactly 0 (ZERO)
    scale = jnp.where((s["passes"] == 0) & pd, jnp.maximum(s["scale"], decrease), s["scale"])
    stationary = pd & (decrease <= tol.grad_tol ** 2 * mag)
    search = pd & ~stationary
    x_new, u_new, c_new, mag_new, found, size = jax.lax.cond(
        search, partial(line_search, problem), partial(no_step, problem),
        x0, s["xs"], s["us"], s["cost"], G, d1, d2, params, search)
    accepted = found & search
    rounding = search & ~found & (decrease <= ROUNDING_TOL * mag)
    mu, delta, mu_up = regularisation(s, accepted)
    status, step = stop_status(s, tol, model.c, pd, stationary, rounding, accepted, mu_up,
                               (x_new, u_new, c_new, mag_new), scale)
    new = dict(xs=x_new, us=u_new, cost=c_new, mag=mag_new, steps=s["steps"] + 1,
               costs=s["costs"].at[s["steps"] + 1].set(c_new), step=step, size=size)
    return {**s, **_where(accepted, new, s), **_where(status == RUNNING, dict(mu=mu, delta=delta), s),
            "G": G, "passes": s["passes"] + 1, "decrease": decrease, "scale": scale,
            "certified": pd & near & (s["mu"] == 0), "ddp": near, "status": status}


def running(s, max_iter):
    """Whether a solve goes on."""
    return (s["status"] == RUNNING) & (s["passes"] < max_iter)


def is_minimum(problem, xs, us, params):
    """Whether every exact (DDP) ``Q_uu + 1e-8 c I`` is positive definite: the block
    factorisation of the Hessian of the cost in the controls, so True at a local minimum (up
    to a relative 1e-8 for flat directions) and False at a saddle or maximum."""
    return backward_pass(quadratic_model(problem, xs, us, params, True), 1e-8)[3]


def finish(problem, end, params):
    """``xs, us, K, costs`` (the accepted costs are ``costs[:steps + 1]``) and the scalars of
    ``SUMMARY`` in one array, once a solve has stopped."""
    # a last exact (DDP) pass at mu = 0 that was positive definite already certified the minimum
    end = dict(end, minimum=jax.lax.cond((end["status"] == CONVERGED) & ~end["certified"], partial(is_minimum, problem),
                                         lambda *_: end["certified"], end["xs"], end["us"], params))
    end["magnitude"], end["start_cost"] = end["mag"], end["costs"][0]
    summary = jnp.stack([end[key].astype(float) for key in SUMMARY])
    return end["xs"], end["us"], end["G"][:, :, 1:], end["costs"], summary
