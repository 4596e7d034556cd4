"""Dragan and Srinivasa's legibility (RSS 2013) on the Dubins car of eq. (7.5), the method whose extension to
a car the thesis calls too slow to plan in real time (line 1064, citing [12]), against the legible objective
of eq. (6.15) solved by iLQR on the same car.

Both robots reach for goal ``g_R`` while the observer also considers ``g_L``; each hypothesis costs
``J_G(u) = a1 |P x_N - G|^2 + a2 dt sum_k u_k^2`` (eq. (7.3)).

* **Theirs.** The observer infers the goal from the motion so far,
  ``P(G | x_{0:t}) ∝ exp(V_G(x_0) - V_G(x_t)) P(G)`` (the running cost of the prefix is the same for every
  goal and cancels), with ``V_G(x_t)`` the optimal cost-to-go from the state reached at stage ``t``. A car
  has no closed form for it, so every evaluation solves all ``N |G|`` continuations (one iLQR batch,
  :func:`mutual.motion.trajopt.ilqr_batch`, warm-started from the previous evaluation); by the envelope
  theorem ``dV_G/dx_t`` is the continuation's cost gradient in its start state at its optimal controls.
  Legibility is ``sum_t w_t P(g_R | x_{0:t})`` with D&S's weights ``f(t) = T - t``, maximised from the
  predictable optimum subject to their trust region ``J_R(u) <= beta J_R*`` by SLSQP with exact gradients.
* **Ours.** One iLQR solve of ``(1 + alpha) J_R - J_L`` (eq. (6.15)), written literally with both goals.
"""

import time
from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
from scipy.optimize import minimize
from scipy.special import softmax

from ..legible.dragan import score_weights
from ..trajopt import ilqr, ilqr_batch
from . import safety as es
from .mpc import _frozen_running, _frozen_step, _frozen_terminal

WEIGHTS = (800.0, 10.0)    # Fig. 7.2's a1 and a2 (eq. (7.3))


def two_goal_task(steps=50, goals=((-1.5, 4.0), (1.5, 4.0)), x0=(0.0, 0.0, np.pi / 2), horizon=1.5):
    """The comparison's car: starts at the origin heading north between two goals ahead (the second is
    the truth); ``horizon`` 1.5 s at v = 3 covers 4.5 m against 4.3 m to either goal. ``(task, goals)``."""
    goals = np.asarray(goals, float)
    return es.EvidentSafetyTask(x0=x0, goal=goals[1], horizon=horizon, steps=steps), goals


def _legible_terminal(x, params):
    p = es.project(x)
    return params["a1"] * ((1 + params["alpha"]) * jnp.sum((p - params["goal_R"]) ** 2)
                           - jnp.sum((p - params["goal_L"]) ** 2))


def legible_problem(task, goals, alpha=es.LEGIBLE_ALPHA, weights=WEIGHTS):
    """``(dynamics, running, terminal, x0, params)`` of ``(1 + alpha) J_R - J_L`` with both goals' terminal costs
    evaluated (the effort terms combine to ``alpha a2``)."""
    a1, a2 = weights
    params = {**task.params(es.hypothesis_weights(0.0, alpha * a2)), "a1": np.float64(a1),
              "alpha": np.float64(alpha), "goal_R": np.asarray(goals[1], float), "goal_L": np.asarray(goals[0], float)}
    return es._step, es._running, _legible_terminal, task.x0, params


def solve_ours(task, goals, alpha=es.LEGIBLE_ALPHA, weights=WEIGHTS):
    """Our legible path: one iLQR solve of :func:`legible_problem` from rest."""
    dyn, run, term, x0, params = legible_problem(task, goals, alpha, weights)
    return ilqr(dyn, run, term, x0, task.zero_controls(), params)


def _continuation_cost(z0, us, params):
    def stage(z, u):
        return _frozen_step(z, u, params), _frozen_running(z, u, params)
    zN, costs = jax.lax.scan(stage, z0, us)
    return jnp.sum(costs) + _frozen_terminal(zN, params)


_STATE_GRADIENTS = jax.jit(jax.vmap(jax.grad(_continuation_cost)))


class Continuations:
    """``V_G(x_t)`` and ``dV_G/dx_t`` for every prefix end ``t = 0 .. N`` and goal: one iLQR batch per call,
    each member warm-started from its previous solution."""

    def __init__(self, task, goals, weights=WEIGHTS):
        self.task, self.goals, self.N = task, np.asarray(goals, float), task.steps
        times = np.tile(np.arange(self.N + 1), len(self.goals))
        params = [{**replace(task, goal=g).params(es.hypothesis_weights(*weights)), "start": np.float64(t)}
                  for g in self.goals for t in range(self.N + 1)]
        self.params = {k: np.stack([p[k] for p in params]) for k in params[0]}
        self.live = np.arange(self.N)[None, :, None] >= times[:, None, None]
        self.us = np.zeros((len(times), self.N, task.controls))
        self.solves = 0

    def __call__(self, xs):
        """``(V (G, N+1), dV/dx (G, N+1, n))`` along the states ``xs`` (N+1, n)."""
        G, n = len(self.goals), xs.shape[1]
        z0 = np.concatenate([np.tile(xs, (G, 1)), np.zeros((G * (self.N + 1), 1))], axis=1)
        guess = np.where(self.live, self.us, 0.0)
        batch = ilqr_batch(_frozen_step, _frozen_running, _frozen_terminal, z0, guess, self.params,
                           second_order="auto", max_iter=500)
        results = [r if r is not None else ilqr(_frozen_step, _frozen_running, _frozen_terminal, z0[i], guess[i],
                                                {k: v[i] for k, v in self.params.items()}, max_iter=2000)
                   for i, r in enumerate(batch.results)]                   # a member the batch did not finish
        self.us = np.stack([r.us for r in results])
        self.solves += 1
        with jax.enable_x64(True):
            grads = np.asarray(_STATE_GRADIENTS(jnp.asarray(z0), jnp.asarray(self.us), self.params))
        costs = np.array([r.cost for r in results])
        return costs.reshape(G, self.N + 1), grads[:, :n].reshape(G, self.N + 1, n)


def _posterior_score(us, task, V0, V, dV, xs_ref, weights, prior_logits):
    """D&S's score with ``V_G`` linearised around the reference states: its value and gradient at the
    reference controls are the true score's (the envelope theorem)."""
    params = task.params(np.zeros(len(es.FEATURES)))

    def score(u):
        def step(x, uk):
            nxt = es._step(x, uk, params)
            return nxt, nxt
        _, tail = jax.lax.scan(step, jnp.asarray(task.x0), u)
        states = jnp.concatenate([jnp.asarray(task.x0)[None], tail])
        v = V + jnp.einsum("gtn,tn->gt", dV, states - xs_ref)
        logits = V0[:, None] - v + prior_logits[:, None]
        return jnp.sum(weights * jax.nn.softmax(logits, axis=0)[-1])
    return jax.value_and_grad(score)(us)


def legibility(task, goals, us, continuations, prior=None):
    """D&S's legibility of the controls ``us`` for the last goal and its gradient (N, m)."""
    xs = es.rollout(task, us)
    V, dV = continuations(xs)
    prior_logits = np.log(np.full(len(goals), 1.0 / len(goals)) if prior is None else np.asarray(prior, float))
    with jax.enable_x64(True):
        value, grad = _posterior_score(jnp.asarray(us), task, jnp.asarray(V[:, 0]), jnp.asarray(V), jnp.asarray(dV),
                                       jnp.asarray(xs), jnp.asarray(score_weights(task.steps)),
                                       jnp.asarray(prior_logits))
    return float(value), np.asarray(grad), softmax(V[:, :1] - V + prior_logits[:, None], axis=0)[-1]


def solve_theirs(task, goals, beta_ratio=1.5, tol=1e-6, max_iter=200, weights=WEIGHTS):
    """D&S on the car: maximise :func:`legibility` s.t. ``J_R(u) <= beta_ratio J_R*`` by SLSQP (``ftol = tol``)
    from the predictable optimum. Returns a dict: ``us``, ``xs``, ``score``, ``posterior`` (N+1,),
    ``iterations``, ``continuation_batches`` (iLQR batches of N |G| continuations solved) and ``success``."""
    w = es.hypothesis_weights(*weights)
    predictable = es.solve(task, w)
    bound = beta_ratio * predictable.cost
    conts = Continuations(task, goals, weights)
    shape = predictable.us.shape
    memo = {}

    def evaluate(flat):
        key = flat.tobytes()
        if key not in memo:
            memo.clear()
            memo[key] = legibility(task, goals, flat.reshape(shape), conts)
        return memo[key]

    def cost_constraint(flat):
        return bound - es.cost(task, w, flat.reshape(shape))

    def cost_constraint_grad(flat):
        return -es.cost_gradient(task, w, flat.reshape(shape))[1].ravel()

    result = minimize(lambda f: -evaluate(f)[0], predictable.us.ravel(), jac=lambda f: -evaluate(f)[1].ravel(),
                      method="SLSQP", constraints=[{"type": "ineq", "fun": cost_constraint, "jac": cost_constraint_grad}],
                      options={"ftol": tol, "maxiter": max_iter})
    us = result.x.reshape(shape)
    score, _, posterior = legibility(task, goals, us, conts)
    return {"us": us, "xs": es.rollout(task, us), "score": score, "posterior": posterior,
            "iterations": int(result.nit), "continuation_batches": conts.solves, "success": bool(result.success),
            "predictable": predictable}


def time_both(task, goals, repeats=5, alpha=es.LEGIBLE_ALPHA, **theirs):
    """Wall-clock seconds of D&S on the car (:func:`solve_theirs`, one run after a one-iteration warm-up that
    compiles its kernels) and of ours (:func:`solve_ours`, best of ``repeats`` after a warm-up); compile
    times are measured apart. Returns a dict with both times, their ratio, both compile times and both
    solutions, and D&S's score of our path (how legible it is by their measure)."""
    start = time.perf_counter()
    solve_theirs(task, goals, **{**theirs, "max_iter": 1})
    compile_theirs = time.perf_counter() - start
    start = time.perf_counter()
    their = solve_theirs(task, goals, **theirs)
    t_theirs = time.perf_counter() - start
    start = time.perf_counter()
    ours = solve_ours(task, goals, alpha)
    compile_ours = time.perf_counter() - start
    t_ours = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        solve_ours(task, goals, alpha)
        t_ours = min(t_ours, time.perf_counter() - start)
    conts = Continuations(task, goals)
    our_score = legibility(task, goals, ours.us, conts)[0]
    return {"seconds theirs": t_theirs, "seconds ours": t_ours, "ratio": t_theirs / t_ours,
            "compile theirs": max(compile_theirs - 0.0, 0.0), "compile ours": max(compile_ours - t_ours, 0.0),
            "theirs": their, "ours": ours, "D&S score theirs": their["score"], "D&S score ours": our_score}
