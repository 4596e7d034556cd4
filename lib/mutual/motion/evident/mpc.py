"""Legible model predictive control on nonlinear dynamics: the receding horizon of eq. (6.16)
solved by iLQR (the "LMPC" of chapter 7, section 7.4's "anticipation and exaggeration ... across
optimal control frameworks like LQR, iLQR, and MPC").

The robot replans at steps ``t_i = 0, every, 2 every, ...`` on the remaining horizon
``[t_i, N)`` from the state it has reached, minimising ``(1 + alpha(t_i / N)) J1 - J0`` with an
increasing ``alpha`` (communication first, the task later), and follows each plan until the
next replanning.

So that every replanning shares one compiled iLQR, each remaining-horizon problem is posed on
the full horizon with its first ``t_i`` stages frozen: the state carries the stage index, and a
frozen stage keeps the state, costs ``|u|^2`` (so its optimal control is 0) and adds nothing
else. The frozen stages are exact no-ops, so the solution on the live stages is the
remaining-horizon optimum.
"""

import jax.numpy as jnp
import numpy as np

from ..trajopt import ILQRError, ilqr, ilqr_batch
from . import safety as es


def _frozen_step(z, u, params):
    x, k = z[:-1], z[-1]
    live = k >= params["start"]
    return jnp.concatenate([jnp.where(live, es._step(x, u, params), x), (k + 1)[None]])


def _frozen_running(z, u, params):
    x, k = z[:-1], z[-1]
    return jnp.where(k >= params["start"], es._running(x, u, params), jnp.sum(u ** 2))


def _frozen_terminal(z, params):
    return es._terminal(z[:-1], params)


def receding_horizon_ilqr(task, w0, w1, alpha_of_s, every=1, **ilqr_options):
    """Anticipative legible control by receding horizon (eq. (6.16)) with iLQR on ``task``'s dynamics.

    ``alpha_of_s(s)`` gives the weight for a replanning at ``s = t_i / N`` (e.g.
    :func:`mutual.motion.legible.objective.linear_alpha_schedule`). Each replanning is warm-started from
    the previous plan. Returns ``{"xs": (N+1, n), "us": (N, m), "alphas": (N,), "replans": int,
    "iterations": list}`` where ``alphas[k]`` is the weight in force at step ``k``.
    """
    if not isinstance(task, es.EvidentSafetyTask):
        raise ValueError(f"task must be an EvidentSafetyTask, got {type(task).__name__}")
    if isinstance(every, (bool, np.bool_)) or not (isinstance(every, (int, np.integer)) and every >= 1):
        raise ValueError(f"every must be a positive integer, got {every!r}")
    if not callable(alpha_of_s):
        raise ValueError(f"alpha_of_s must be callable, got {type(alpha_of_s).__name__}")
    N = task.steps
    starts = np.arange(0, N, every)
    alphas = np.array([float(alpha_of_s(t / N)) for t in starts])
    if not np.all(np.isfinite(alphas)):
        raise ValueError(f"alpha_of_s returned non-finite weights {alphas.tolist()}")
    xs = np.empty((N + 1, task.x0.shape[0]))
    us = np.zeros((N, task.controls))
    xs[0] = task.x0
    plan = task.zero_controls()
    iterations = []
    for i, (t, alpha) in enumerate(zip(starts, alphas)):
        params = {**task.params(es.legible_weights(w1, w0, alpha)), "start": np.float64(t)}
        guess = np.where(np.arange(N)[:, None] >= t, plan, 0.0)
        z0 = np.append(xs[t], 0.0)
        result = ilqr(_frozen_step, _frozen_running, _frozen_terminal, z0, guess, params, **ilqr_options)
        plan = result.us
        iterations.append(result.iterations)
        stop = starts[i + 1] if i + 1 < len(starts) else N
        us[t:stop] = plan[t:stop]
        xs[t:stop + 1] = result.xs[t:stop + 1, :-1]
    return {"xs": xs, "us": us, "alphas": alphas[np.arange(N) // every], "replans": len(starts),
            "iterations": iterations}


def receding_horizon_ilqr_batch(tasks, w0, w1, schedules, every=1, **ilqr_options):
    """:func:`receding_horizon_ilqr` for several members at once (one :func:`mutual.motion.trajopt.ilqr_batch`
    per replanning): ``tasks`` (B tasks of the same dynamics and steps, e.g. other hazards) and ``schedules``
    (B alpha schedules) pair up member by member. Returns a list of B dicts like
    :func:`receding_horizon_ilqr`'s. A member the batch does not finish is solved again alone by
    :func:`mutual.motion.trajopt.ilqr` (Gauss-Newton, then DDP near the minimum; up to 2000 iterations), whose
    ILQRError stops the run."""
    tasks, schedules = list(tasks), list(schedules)
    if not tasks or len(tasks) != len(schedules) or not all(isinstance(t, es.EvidentSafetyTask) for t in tasks):
        raise ValueError("tasks and schedules must be equally long, non-empty, and tasks EvidentSafetyTasks")
    if isinstance(every, (bool, np.bool_)) or not (isinstance(every, (int, np.integer)) and every >= 1):
        raise ValueError(f"every must be a positive integer, got {every!r}")
    N, B = tasks[0].steps, len(tasks)
    if any(t.steps != N or t.x0.shape != tasks[0].x0.shape for t in tasks):
        raise ValueError("tasks must share the dynamics and the number of steps")
    starts = np.arange(0, N, every)
    alphas = np.array([[float(f(t / N)) for t in starts] for f in schedules])
    if not np.all(np.isfinite(alphas)):
        raise ValueError("a schedule returned non-finite weights")
    xs = np.empty((B, N + 1, tasks[0].x0.shape[0]))
    us = np.zeros((B, N, tasks[0].controls))
    xs[:, 0] = [t.x0 for t in tasks]
    plan = np.zeros_like(us)
    iterations = [[] for _ in range(B)]
    for i, t in enumerate(starts):
        params = [{**task.params(es.legible_weights(w1, w0, alphas[b, i])), "start": np.float64(t)}
                  for b, task in enumerate(tasks)]
        stacked = {k: np.stack([p[k] for p in params]) for k in params[0]}
        guess = np.where(np.arange(N)[None, :, None] >= t, plan, 0.0)
        z0 = np.concatenate([xs[:, t], np.zeros((B, 1))], axis=1)
        batch = ilqr_batch(_frozen_step, _frozen_running, _frozen_terminal, z0, guess, stacked, **ilqr_options)
        results = [batch.results[b] if batch.results[b] is not None else       # a member the batch did not finish:
                   ilqr(_frozen_step, _frozen_running, _frozen_terminal, z0[b], guess[b], params[b], max_iter=2000)
                   for b in range(B)]                                         # alone, with DDP near the end
        for b, result in enumerate(results):
            plan[b] = result.us
            iterations[b].append(result.iterations)
        stop = starts[i + 1] if i + 1 < len(starts) else N
        us[:, t:stop] = plan[:, t:stop]
        xs[:, t:stop + 1] = np.stack([r.xs[t:stop + 1, :-1] for r in results])
    return [{"xs": xs[b], "us": us[b], "alphas": alphas[b][np.arange(N) // every], "replans": len(starts),
             "iterations": iterations[b]} for b in range(B)]


def continuation_costs(task, weights, states, times, guesses=(), **ilqr_options):
    """The optimal cost-to-go ``V_t(x)`` of the feature cost with ``weights`` from each state
    ``states[i]`` at stage ``times[i]`` to the end of ``task``'s horizon (len(times),).

    Every continuation is solved by iLQR on the frozen-stage problem from zero controls and from
    each of ``guesses`` (control sequences (N, m), e.g. the hypothesis's optimum and the observed
    motion's own controls); ``V_t`` is the lowest converged cost (continuations are non-convex).
    One solve at a time: their difficulty varies so much that a batch, which runs until its
    slowest member stops, was measured slower. Raises ValueError naming the stages where no start
    converged."""
    N = task.steps
    times = np.asarray(times, int)
    states = np.asarray(states, float)
    starts = [task.zero_controls()] + [np.asarray(g, float) for g in guesses]
    base = task.params(weights)
    out, failed, message = np.full(len(times), np.inf), [], ""
    for i, (t, x) in enumerate(zip(times, states)):
        params = {**base, "start": np.float64(t)}
        live = np.arange(N)[:, None] >= t
        for guess in starts:
            try:
                r = ilqr(_frozen_step, _frozen_running, _frozen_terminal, np.append(x, 0.0),
                         np.where(live, guess, 0.0), params, **ilqr_options)
            except ILQRError as err:
                message = str(err)
                continue
            out[i] = min(out[i], r.cost)
        if not np.isfinite(out[i]):
            failed.append(int(t))
    if failed:
        raise ValueError(f"the optimal continuation did not converge from stages {failed}: {message}")
    return out
