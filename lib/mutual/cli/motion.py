"""``mutual motion legible``: legible motion towards a goal among distractors (chapter 6).

Reads a legibility spec (:mod:`mutual.motion.spec`), solves the legible objective
``(1 + alpha) J1 - J0`` of eq. (6.15) by LQR (single integrator; receding horizon for
anticipation, eq. 6.16; the multi-distractor QP of section 6.5 with ``eta``) or iLQR (Dubins
car), and writes the trajectory as CSV and a figure beside the predictable (H1-optimal) motion.
"""

from .. import budget
from . import common

DESCRIPTION = """\
Legible motion as hypothesis testing (chapter 6): a robot reaching for GOAL moves so that an
observer who also considers the DISTRACTORS tells early and surely which goal it is after.
The hypotheses are reaching costs J_i = w_T |p_N - g_i|^2 + w_u int |u|^2 dt (eq. 6.17); the
legible motion minimises (1 + alpha) J_1 - J_0 (eq. 6.15), which by Theorem 6.4.2 minimises the
observer's likelihood ratio P(u | H0) / P(u | H1). SPEC.toml sets the dynamics (single integrator:
exact LQR and the observer's evidence in time linear in the steps, about 2 s in all for 10 000
steps, most of it starting up and drawing; Dubins car: iLQR, about 10-30 s the first time while JAX
compiles), the start, goal, distractors, horizon, steps and alpha (or eta for the multi-distractor
QP, and an optional [anticipation] schedule); format and limits: data/README.md.

writes to --out:  legible_trajectory.csv (t, x, y[, theta], the controls, and the predictable
                  motion beside it), legible_trajectory.png (both paths, goal and distractors)
"""

EXAMPLE = """\
example:
  mutual motion legible data/examples/legible.toml
"""


def register(subparsers):
    """Add ``mutual motion`` and its ``legible`` command."""
    commands = common.command_group(subparsers, "motion",
                                    "legible motion between a goal and distractors (chapters 6-7)",
                                    "Robots informing humans through motion (chapters 6-7).")
    legible = common.add_command(commands, "legible", "legible LQR / iLQR trajectory from a TOML spec", DESCRIPTION,
                                 EXAMPLE)
    legible.add_argument("spec", metavar="SPEC.toml", help="the legibility spec (format: data/README.md)")
    common.add_output_options(legible)
    legible.set_defaults(handler=run_legible, prog=legible.prog)


def trajectory_table(spec, solution):
    """One row per knot k = 0..N: time, the legible state and control (empty on the last row) and the
    predictable (H1-optimal) state, as a DataFrame."""
    import numpy as np
    import pandas as pd
    xs, us = solution["legible"]
    ps, _ = solution["predictable"]
    names = ["x", "y", "theta"][:xs.shape[1]]
    controls = ["u_turn"] if spec.dynamics == "dubins" else ["u_x", "u_y"]
    table = pd.DataFrame({"k": np.arange(len(xs)), "t": spec.dt * np.arange(len(xs))})
    for i, n in enumerate(names):
        table[n] = xs[:, i]
    for i, n in enumerate(controls):
        table[n] = np.append(us[:, i], np.nan)
    if "alphas" in solution:
        table["alpha"] = np.append(solution["alphas"], np.nan)
    for i, n in enumerate(names):
        table[f"predictable_{n}"] = ps[:, i]
    return table


def run_legible(args):
    from ..motion import load_legible_spec, solve_legible
    path = common.existing_file(args.spec)
    with common.about(path):
        spec = load_legible_spec(path)
    budget.check(budget.legible(spec.steps, 1 + len(spec.distractors), spec.dynamics))     # before the solve starts
    with common.progress(args, total=1, desc=f"solving ({spec.method})", unit="problem") as bar:
        with common.about(path):
            solution = solve_legible(spec)
        bar.update(1)
    table = trajectory_table(spec, solution)
    with common.output_set(args) as files:
        outputs = {"trajectory": files.csv(table, "legible_trajectory.csv"),
                   "figure": files.figure(_figure(spec, solution), "legible_trajectory.png")}
    xs, ps = solution["legible"][0], solution["predictable"][0]
    results = {
        "command": "motion legible", "input": str(path), "dynamics": spec.dynamics, "method": solution["method"],
        "goal": spec.goal, "distractors": spec.distractors, "horizon": spec.horizon, "steps": spec.steps,
        "alpha": spec.alpha, "eta": spec.eta, "anticipation": spec.anticipation,
        "final_position": xs[-1, :2], "predictable_final_position": ps[-1, :2],
        "evidence_kind": solution["evidence_kind"], "evidence": solution["evidence"],
        "duals": solution.get("duals"),
        "outputs": {k: str(v) for k, v in outputs.items()},
    }
    common.report(args, _summary(results), results)


def _figure(spec, solution):
    common.use_agg()
    import matplotlib.pyplot as plt
    import numpy as np
    from ..style import PALETTE
    xs, ps = solution["legible"][0], solution["predictable"][0]
    fig, ax = plt.subplots(figsize=(5.2, 4.0))
    ax.plot(ps[:, 0], ps[:, 1], color="0.55", ls="--", label="predictable: min J1")
    label = {"qp": "legible: QP, J1 - J0 <= eta", "receding-horizon": "legible: anticipative (1+alpha(t)) J1 - J0"}
    ax.plot(xs[:, 0], xs[:, 1], color=PALETTE["green"], lw=2,
            label=label.get(solution["method"], "legible: min (1+alpha) J1 - J0"))
    step = max(1, len(xs) // 10)
    ax.plot(xs[::step, 0], xs[::step, 1], "o", ms=3, color=PALETTE["green"])
    ax.plot(*spec.start[:2], "o", color="black", ms=5, label="start")
    ax.plot(*spec.goal, "*", color=PALETTE["blue"], ms=14, label="goal g1")
    d = np.array(spec.distractors)
    ax.plot(d[:, 0], d[:, 1], "X", color=PALETTE["vermillion"], ms=9, label="distractors g0")
    ax.set_xlabel("x (units of the spec)")
    ax.set_ylabel("y (units of the spec)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(f"{spec.dynamics}, T = {spec.horizon:g} s, N = {spec.steps}; dots every {step} steps", fontsize=8)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.02, 0.5))
    return fig


def _summary(r):
    how = {"lqr": f"LQR, alpha = {r['alpha']:g}" if r["alpha"] else "LQR",
           "receding-horizon": "receding-horizon LQR, alpha from {:g} to {:g}, replanned every {} step(s)".format(
               *(r["anticipation"] or (0, 0, 0))),
           "qp": f"multi-distractor QP, eta = {r['eta']:g}" if r["eta"] is not None else "QP",
           "ilqr": f"iLQR, alpha = {r['alpha']:g}" if r["alpha"] else "iLQR"}[r["method"]]
    fx, fy = r["final_position"]
    px, py = r["predictable_final_position"]
    kind = r["evidence_kind"]
    lines = [f"Legible motion ({r['dynamics']}, {how}) from {r['input']}", "",
             f"  goal g1 = ({r['goal'][0]:g}, {r['goal'][1]:g}); distractors: "
             + ", ".join(f"({x:g}, {y:g})" for x, y in r["distractors"]),
             f"  final position: legible ({fx:.4g}, {fy:.4g}); predictable ({px:.4g}, {py:.4g})", "",
             f"  evidence against each distractor, {kind}"
             + (" (nats; negative favours the goal)" if kind == "log Lambda" else " (favours the goal when negative)")]
    for i, g in enumerate(r["distractors"]):
        lines.append(f"    vs ({g[0]:g}, {g[1]:g}): legible {r['evidence']['legible'][i]:.4g}, "
                     f"predictable {r['evidence']['predictable'][i]:.4g}")
    lines += ["", "wrote " + ", ".join(r["outputs"].values())]
    return "\n".join(lines)
