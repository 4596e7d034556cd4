"""Our iLQR against crocoddyl's FDDP (C++; Mastalli et al. 2020) on crocoddyl's own unicycle.

The problem is crocoddyl's ``ActionModelUnicycle`` as it comes (``include/crocoddyl/core/actions/
unicycle.hxx``): dt = 0.1, cost weights (10, 1), one model for every running node and the terminal::

    x' = x + dt (v cos th, v sin th, w),   l(x, u) = 1/2 |10 x|^2 + 1/2 |u|^2,   l_N(x) = 1/2 |10 x|^2

(no dt in the cost), with N = 100 and N = 1000 nodes from the start of crocoddyl's unicycle example
(``notebooks/unicycle_towards_origin.py``: x0 = (-1, -1, 1)). Our side writes the same model in JAX
(checked against crocoddyl's ``calc``/``calcDiff`` at random points to 1e-12) and solves it with
:func:`mutual.motion.trajopt.ilqr` from zero controls, with its default settings. FDDP runs with its
defaults (``th_stop`` 1e-9 on the expected improvement, 100 iterations at most), from its default
start (``solve()``: zero states and controls, infeasible) and from the rollout of zero controls (the
start ours gets); the faster of the two is the baseline. FDDP runs on one thread
(``problem.nthreads = 1``; ``make bench-peers`` also sets ``OMP_NUM_THREADS=1``): the wheel's default,
2 threads here, only adds OpenMP hand-offs for this small model (on the loaded 2-core machine FDDP
took 1.2x-500x longer with 2 threads, and the spinning worker threads slowed the solves timed after
it). Times are
per solve, the median of many interleaved calls after a warm-up; our compile time (first call, with
an empty JAX compilation cache under ``make bench-peers``) is reported apart.

Each size is measured twice: in this process, with JAX's defaults, and in a fresh process with
JAX's synchronous CPU dispatch (``jax.config.update("jax_cpu_enable_async_dispatch", False)``
before the first computation), which runs each solve on the calling thread instead of handing it
to a worker thread and waiting; on a loaded machine that hand-off, not the solver, is what a
millisecond solve waits on. The results are the same (the same compiled program runs).
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import crocoddyl
import jax
import jax.numpy as jnp
import numpy as np

from mutual.motion.trajopt import ilqr

sys.path.insert(0, str(Path(__file__).parent))
from peer_timing import interleaved, timed  # noqa: E402

X0 = np.array([-1.0, -1.0, 1.0])  # crocoddyl's unicycle example
AGREE = 1e-8  # relative agreement of the two optimal costs
MODEL_AGREE = 1e-12  # our JAX model against crocoddyl's calc/calcDiff


def unicycle_step(x, u, params):
    """crocoddyl's unicycle: ``x + dt (v cos th, v sin th, w)``."""
    dt = params["dt"]
    return jnp.stack([x[0] + jnp.cos(x[2]) * u[0] * dt, x[1] + jnp.sin(x[2]) * u[0] * dt, x[2] + u[1] * dt])


def unicycle_cost(x, u, params):
    """``1/2 |r|^2`` with the residual ``r = (w_x x, w_u u)``."""
    r = jnp.concatenate([params["weights"][0] * x, params["weights"][1] * u])
    return 0.5 * r @ r


def unicycle_terminal(x, params):
    r = params["weights"][0] * x
    return 0.5 * r @ r


def _params(model):
    return {"dt": np.float64(model.dt), "weights": np.asarray(model.costWeights, float)}


def model_gap(model, samples=50, seed=0):
    """Largest difference between crocoddyl's ``calc``/``calcDiff`` and our JAX model (next state,
    cost, and their first and second derivatives) at random states and controls."""
    data, params, rng = model.createData(), _params(model), np.random.default_rng(seed)
    with jax.enable_x64(True):
        f = jax.jit(lambda x, u: (unicycle_step(x, u, params), unicycle_cost(x, u, params),
                                  jax.jacfwd(unicycle_step, (0, 1))(x, u, params),
                                  jax.grad(unicycle_cost, (0, 1))(x, u, params),
                                  jax.hessian(unicycle_cost, (0, 1))(x, u, params)))
        term = jax.jit(lambda x: (unicycle_terminal(x, params), jax.grad(unicycle_terminal)(x, params),
                                  jax.hessian(unicycle_terminal)(x, params)))
        gap = 0.0
        for _ in range(samples):
            x, u = rng.normal(size=3) * [2, 2, np.pi], rng.normal(size=2)
            model.calc(data, x, u)
            model.calcDiff(data, x, u)
            xn, c, (Fx, Fu), (Lx, Lu), ((Lxx, _), (_, Luu)) = f(x, u)
            # crocoddyl's data fields are views of its buffers: copied before the terminal calc reuses them
            pairs = [(xn, data.xnext.copy()), (c, data.cost), (Fx, data.Fx.copy()), (Fu, data.Fu.copy()),
                     (Lx, data.Lx.copy()), (Lu, data.Lu.copy()), (Lxx, data.Lxx.copy()), (Luu, data.Luu.copy())]
            model.calc(data, x)
            model.calcDiff(data, x)
            cN, LxN, LxxN = term(x)
            pairs += [(cN, data.cost), (LxN, data.Lx), (LxxN, data.Lxx)]
            gap = max(gap, max(float(np.max(np.abs(np.asarray(a) - np.asarray(b)))) for a, b in pairs))
    return gap


def _fddp(N, feasible):
    model = crocoddyl.ActionModelUnicycle()
    problem = crocoddyl.ShootingProblem(X0, [model] * N, model)
    problem.nthreads = 1
    solver = crocoddyl.SolverFDDP(problem)
    if feasible:
        us = [np.zeros(2)] * problem.T
        xs = problem.rollout(us)

        def solve():
            solver.solve(xs, us, 100, True)
            return solver
    else:
        def solve():
            solver.solve()
            return solver
    return solve


# FDDP's two starts: its default (zero states and controls) and the rollout of zero controls (ours)
VARIANTS = {"zero start": False, "rollout start": True}


def _case(N, runs, sync=False):
    params, us0 = _params(crocoddyl.ActionModelUnicycle()), np.zeros((N, 2))

    def ours():
        return ilqr(unicycle_step, unicycle_cost, unicycle_terminal, X0, us0, params)

    first, _ = timed(ours)
    times, outs = interleaved([ours] + [_fddp(N, v) for v in VARIANTS.values()], runs)
    t_ours, r = times[0], outs[0]
    # FDDP's ``iter`` is the index of its last iteration: one more backward pass and step than that
    fddp = {k: (t, s.iter + 1, s.cost, s.isFeasible, np.array(s.us)) for k, t, s in zip(VARIANTS, times[1:], outs[1:])}
    fddp_cost = min(v[2] for v in fddp.values())
    start, (t_base, its, _, _, us_croc) = min(fddp.items(), key=lambda kv: kv[1][0]["median"])
    gap = abs(r.cost - fddp_cost) / abs(fddp_cost)
    spread = max(abs(v[2] - fddp_cost) for v in fddp.values()) / abs(fddp_cost)
    agree = bool(gap <= AGREE and spread <= AGREE and all(v[3] for v in fddp.values()))
    ratio = t_base["median"] / t_ours["median"]
    per_pass, per_iter = t_ours["median"] / r.passes, t_base["median"] / its
    detail = "; ".join(f"FDDP {k}: {v[0]['median'] * 1e3:.3g} ms, {v[1]} it" for k, v in fddp.items())
    how = "JAX synchronous CPU dispatch (fresh process)" if sync else "JAX defaults"
    return {"benchmark": "peers: crocoddyl", "case": (
        f"crocoddyl's unicycle (ActionModelUnicycle, dt 0.1, weights 10/1), N={N}, x0=(-1,-1,1), {how}: iLQR "
        f"{r.iterations} it / {r.passes} passes ({per_pass * 1e6:.0f} us per pass), FDDP {its} it "
        f"(passes), {start} ({per_iter * 1e6:.0f} us per pass)"),
        "seconds": t_ours["median"],
        "baseline": (f"crocoddyl {crocoddyl.__version__} SolverFDDP (C++), default settings, the faster of its two "
                     "starts, 1 thread"),
        "baseline_seconds": t_base["median"], "compile_seconds": first - t_ours["median"],
        "agree": (f"{agree}: costs {r.cost:.12g} (ours) / {fddp_cost:.12g} (FDDP), relative gap {gap:.1e} "
                  f"(target {AGREE:g}), every FDDP variant within {spread:.0e}, max |du| "
                  f"{np.max(np.abs(r.us - us_croc)):.1e}; {detail}; medians of "
                  f"{t_ours['runs']} interleaved solves, ours {t_ours['min'] * 1e3:.3g}-{t_ours['max'] * 1e3:.3g} ms, "
                  f"FDDP {t_base['min'] * 1e3:.3g}-{t_base['max'] * 1e3:.3g} ms"),
        "target": ">= 1x crocoddyl per solve, costs to 1e-8", "met": bool(agree and ratio >= 1.0)}


def _sync_case(N, runs):
    """:func:`_case` with JAX's synchronous CPU dispatch, in a fresh process (the setting must
    precede the first computation of a process)."""
    out = subprocess.run([sys.executable, __file__, "sync", str(N), str(runs)], capture_output=True, text=True,
                         check=True, env=os.environ)
    return json.loads(out.stdout.strip().splitlines()[-1])


def run(quick=False):
    gap = model_gap(crocoddyl.ActionModelUnicycle())
    rows = [{"benchmark": "peers: crocoddyl", "case": "our JAX unicycle against crocoddyl's calc/calcDiff, 50 random "
             "(x, u): next state, cost, F_x, F_u, L_x, L_u, L_xx, L_uu and the terminal cost's", "seconds": None,
             "baseline": "", "baseline_seconds": None, "compile_seconds": None,
             "agree": f"max abs difference {gap:.1e}", "target": f"<= {MODEL_AGREE:g}", "met": bool(gap <= MODEL_AGREE)}]
    for N, runs in ((100, 20 if quick else 200), (1000, 5 if quick else 50)):
        rows += [_case(N, runs), _sync_case(N, runs)]
    return rows


if __name__ == "__main__":
    if sys.argv[1:2] == ["sync"]:
        jax.config.update("jax_cpu_enable_async_dispatch", False)
        print(json.dumps(_case(int(sys.argv[2]), int(sys.argv[3]), sync=True)))
    else:
        for row in run(quick=True):
            print(row)
