"""The Dubins-car legibility spec (``dynamics = "dubins"`` in :mod:`mutual.motion.spec`): the car of
eq. (7.5) (state ``(x, y, theta)``, constant speed, turn rate ``u``) reaching for the goal among the
distractors, solved by iLQR (:func:`mutual.motion.trajopt.ilqr`) from several constant-turn starts
(the best is kept). The legible objective is ``(1 + alpha) J1 - mean_i J0_i`` (eq. 6.15) with the
reaching costs of eq. (6.17) on the planar end point; the evidence is ``J1 - J0_i`` (``log Lambda`` up
to a constant)."""

import numpy as np

STARTS = (0.0, 0.5, -0.5, 1.0, -1.0)    # constant turn rates (rad/s) iLQR starts from


def step(x, u, params):
    """One step of the car (:func:`mutual.dubins.step_jax`)."""
    from ..dubins import step_jax
    return step_jax(x, u, params["dt"], params["speed"])


def running(x, u, params):
    """The effort ``w_u dt u^2`` of one step."""
    import jax.numpy as jnp
    return params["dt"] * params["effort"] * jnp.sum(u ** 2)


def terminal(x, params):
    """``w1 |p_N - g_1|^2 - sum_i w0 |p_N - g_0i|^2`` on the planar position ``p_N``."""
    import jax.numpy as jnp
    p = x[:2]
    return (params["w1"] * jnp.sum((p - params["goal"]) ** 2)
            - params["w0"] * jnp.sum((p[None, :] - params["distractors"]) ** 2))


def params(spec, w1, w0, effort):
    """The problem's parameters: goal weight ``w1``, weight ``w0`` of each distractor, effort weight."""
    return {"dt": np.float64(spec.dt), "speed": np.float64(spec.speed), "w1": np.float64(w1), "w0": np.float64(w0),
            "effort": np.float64(effort), "goal": np.array(spec.goal), "distractors": np.array(spec.distractors)}


def best_ilqr(spec, problem_params):
    """The lowest-cost iLQR optimum over the constant-turn starts :data:`STARTS`."""
    from .trajopt import ILQRError, ilqr
    found, errors = [], []
    for rate in STARTS:
        try:
            found.append(ilqr(step, running, terminal, np.array(spec.start), np.full((spec.steps, 1), rate),
                              problem_params))
        except ILQRError as err:
            errors.append(str(err))
    if not found:
        raise RuntimeError(f"iLQR found no local minimum from any of the starts {STARTS}: {errors[0]}")
    return min(found, key=lambda r: r.cost)


def solve_dubins(spec):
    """The legible and predictable motions of a Dubins spec, with ``J1 - J0_i`` as evidence (the
    dict of :func:`mutual.motion.spec.solve_legible`)."""
    wT, wu, K, a = spec.terminal_weight, spec.effort_weight, len(spec.distractors), spec.alpha
    # (1 + alpha) J1 - mean J0: goal weight (1 + alpha) wT, each distractor -wT / K, effort alpha wu
    legible = best_ilqr(spec, params(spec, (1 + a) * wT, wT / K, a * wu))
    plain = best_ilqr(spec, params(spec, wT, 0.0, wu))

    def difference(xs):         # J1 - J0_i per distractor (effort cancels), without squaring large numbers
        g1, p = np.array(spec.goal), xs[-1, :2]
        return [float(2 * wT * (g0 - g1) @ (p - (g0 + g1) / 2)) for g0 in np.array(spec.distractors)]

    return {"method": "ilqr", "legible": (legible.xs, legible.us), "predictable": (plain.xs, plain.us),
            "alphas": np.full(spec.steps, a), "evidence_kind": "J1 - J0",
            "evidence": {"legible": difference(legible.xs), "predictable": difference(plain.xs)}}
