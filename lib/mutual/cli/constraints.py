"""``mutual constraints infer``: constraints and chance thresholds from demonstrations (chapters 2-3).

Reads a gridworld (:mod:`mutual.constraints.world`) and demonstrations in it
(:func:`mutual.constraints.load_demonstrations`), proposes one chance constraint per state with
its maximum-likelihood threshold psi* (eq. 3.3) and one constraint per action
(:func:`mutual.constraints.constraint_candidates`), and adds them greedily, best F first
(Algorithm 4, eq. 2.25; :func:`mutual.constraints.greedy_inference`), until the stop rule fires.
"""

from .. import budget
from . import common, continuous

DEFAULT_ROUNDS, DEFAULT_MIN_GAIN, DEFAULT_TOP = 10, 0.1, 5

DESCRIPTION = f"""\
Greedy maximum-likelihood constraint inference with chance thresholds (Sections 2.4, 3.2).

Every state x is a candidate chance constraint with the lowest threshold the demonstrations allow,
psi*(x) = max over demonstrated (x_t, a_t) of S(x_t, a_t, x) (eq. 3.3), and every action is a
candidate forbidden everywhere; candidates that would make a demonstration impossible are dropped.
Each round ranks the rest by F = Z_C+ / Z_C0 (Algorithm 4, eq. 2.25; geometric mean over the
demonstrations), prints the best --top with F and the exact gain in log-likelihood per
demonstration, and adds the smallest F.

Stop rule: after --rounds rounds, or before adding a constraint whose gain -log F is below
--min-gain nats per demonstration (i.e. F > exp(-min_gain); default {DEFAULT_MIN_GAIN} nats, F > 0.905).
Constraints the demonstrations support have small F; once only untrue ones remain F retracts
towards 1 (the thesis's fifth choice had F = 0.96, a gain of 0.04 nats). --min-gain 0 keeps going.

DEMOS.csv: demo, t, state, action (state = col + width * row; action 0..8 = E, NE, N, NW, W, SW,
S, SE, loiter; empty on each demonstration's last row). WORLD.toml: width, height, start, goal,
slip, horizon, miss_penalty, loiter. Formats: data/README.md. A 9 x 9 world with 100
demonstrations takes a few seconds per round.

writes to --out:  constraints_ranking.csv (every feasible candidate in every round: rank, F,
                  -log F, exact gain, chosen), constraints_chosen.csv (the accepted constraints),
                  constraints.png (round-1 F on the grid and the compass; chosen ones crossed)
"""

EXAMPLE = """\
example:
  mutual constraints infer data/examples/demonstrations.csv --world data/examples/world.toml
"""


def register(subparsers):
    """Add ``mutual constraints`` and its ``infer`` command."""
    commands = common.command_group(subparsers, "constraints",
                                    "constraints and chance thresholds from demonstrations (chapters 2-3)",
                                    "Learn constraints from stochastic demonstrations (chapters 2-3).")
    infer = common.add_command(commands, "infer", "greedy constraint inference with chance thresholds", DESCRIPTION,
                               EXAMPLE)
    infer.add_argument("demos", metavar="DEMOS.csv", help="the demonstrations (format: data/README.md)")
    infer.add_argument("--world", required=True, metavar="WORLD.toml", help="the gridworld they were demonstrated in")
    infer.add_argument("--rounds", type=int, default=DEFAULT_ROUNDS,
                       help=f"at most this many constraints (default {DEFAULT_ROUNDS})")
    infer.add_argument("--min-gain", type=float, default=DEFAULT_MIN_GAIN, metavar="NATS",
                       help=f"stop before a constraint whose -log F is below NATS per demonstration "
                            f"(default {DEFAULT_MIN_GAIN})")
    infer.add_argument("--top", type=int, default=DEFAULT_TOP,
                       help=f"candidates to print per round (default {DEFAULT_TOP}; the CSV has all)")
    common.add_output_options(infer)
    infer.set_defaults(handler=run_infer, prog=infer.prog)
    continuous.register(commands)      # infer-continuous and simulate


def _check_options(args):
    import math
    if args.rounds < 1:
        raise common.InputError(f"--rounds {args.rounds}: must be at least 1")
    if not math.isfinite(args.min_gain) or args.min_gain < 0:
        raise common.InputError(f"--min-gain {args.min_gain}: must be a finite number >= 0")
    if args.top < 1:
        raise common.InputError(f"--top {args.top}: must be at least 1")


def _next_round(mdp, demos, cand, result):
    """The ranking of the round after the last accepted one (the one the stop rule refused), or None."""
    import dataclasses
    import numpy as np
    from ..constraints import greedy_inference
    rest = dataclasses.replace(cand, feasible=cand.feasible & ~np.isin(np.arange(len(cand)), result.chosen))
    if not rest.feasible.any():
        return None
    one = greedy_inference(mdp, demos, rest, 1, base_mask=result.mask)
    return (one.log_f[0], one.gain[0]) if one.chosen else None


def ranking_table(grid, cand, rounds, chosen):
    """One row per feasible candidate and round: its rank by F, F, -log F and exact gain; whether chosen."""
    import numpy as np
    import pandas as pd
    from ..constraints import GRID_ACTIONS
    rows = []
    for i, (log_f, gain) in enumerate(rounds):
        live = np.flatnonzero(np.isfinite(gain))
        order = live[np.argsort(log_f[live], kind="stable")]
        for rank, k in enumerate(order, start=1):
            state = cand.kind[k] == "state"
            col, row = grid.coords(cand.index[k]) if state else (None, None)
            rows.append({"round": i + 1, "rank": rank, "kind": str(cand.kind[k]), "index": int(cand.index[k]),
                         "col": None if col is None else int(col), "row": None if row is None else int(row),
                         "action": None if state else GRID_ACTIONS[cand.index[k]],
                         "label": grid.label(cand.kind[k], cand.index[k]),
                         "psi": float(cand.psi[k]) if state else None, "F": float(np.exp(log_f[k])),
                         "neg_log_F": float(-log_f[k]), "exact_gain": float(gain[k]),
                         "chosen": bool(i < len(chosen) and k == chosen[i])})
    columns = ["round", "rank", "kind", "index", "col", "row", "action", "label", "psi", "F", "neg_log_F",
               "exact_gain", "chosen"]
    table = pd.DataFrame(rows, columns=columns)
    for c in ("col", "row"):
        table[c] = table[c].astype("Int64")
    return table


def run_infer(args):
    _check_options(args)
    demos_path = common.existing_file(args.demos)
    world_path = common.existing_file(args.world)
    from ..constraints import constraint_candidates, greedy_inference, load_demonstrations
    from ..constraints import load_world
    with common.about(world_path):
        grid = load_world(world_path)
    mdp = grid.mdp
    budget.check(budget.gridworld_inference(mdp.n_states, mdp.n_actions, mdp.horizon, args.rounds))
    with common.about(demos_path):
        demos = load_demonstrations(demos_path, mdp)
        cand = constraint_candidates(mdp, demos)
    with common.progress(args, total=1, desc="greedy inference", unit="run") as bar:
        result = greedy_inference(mdp, demos, cand, args.rounds, min_gain=args.min_gain, criterion="F")
        bar.update(1)
    rounds = list(zip(result.log_f, result.gain))
    stopped = None
    if len(result.chosen) < args.rounds:
        nxt = _next_round(mdp, demos, cand, result)
        if nxt is not None:
            rounds.append(nxt)
            stopped = "min-gain"
        else:
            stopped = "no candidate left"
    table = ranking_table(grid, cand, rounds, result.chosen)
    chosen = table[table["chosen"]].drop(columns=["rank", "chosen"])
    with common.output_set(args) as files:
        outputs = {"ranking": files.csv(table, "constraints_ranking.csv"),
                   "chosen": files.csv(chosen, "constraints_chosen.csv"),
                   "figure": files.figure(_figure(grid, cand, result), "constraints.png")}
    results = {
        "command": "constraints infer", "input": str(demos_path), "world": str(world_path),
        "n_demonstrations": demos.n, "steps": demos.steps, "n_states": mdp.n_states, "n_actions": mdp.n_actions,
        "rounds": args.rounds, "min_gain": args.min_gain,
        "stopped": stopped or "rounds",
        "chosen": chosen.to_dict(orient="records"),
        "ranking": [table[table["round"] == r].head(args.top).to_dict(orient="records")
                    for r in range(1, len(rounds) + 1)],
        "outputs": {k: str(v) for k, v in outputs.items()},
    }
    common.report(args, _summary(results, args), results)


def _figure(grid, cand, result):
    """Round-1 F of every state (grid) and action (compass), chosen constraints crossed and numbered."""
    common.use_agg()
    import matplotlib.pyplot as plt
    import numpy as np
    from ..constraints import plot_actions, plot_states
    F = np.exp(result.log_f[0]) if result.log_f else np.full(len(cand), np.nan)
    states, actions = cand.kind == "state", cand.kind == "action"
    chosen_states = [cand.index[k] for k in result.chosen if states[k]]
    chosen_actions = [cand.index[k] for k in result.chosen if actions[k]]
    fig, (ax_s, ax_a) = plt.subplots(1, 2, figsize=(6.6, 3.4), gridspec_kw={"width_ratios": [3, 1.4]})
    im = plot_states(ax_s, grid, F[states], crosses=chosen_states, title="states: F in round 1; X: chosen")
    for i, k in enumerate(result.chosen, start=1):
        if states[k]:
            c, r = grid.coords(cand.index[k])
            ax_s.text(c + 0.28, r + 0.28, str(i), color="white", fontsize=7, fontweight="bold")
    plot_actions(ax_a, F[actions], crosses=chosen_actions, title="actions: F in round 1")
    fig.colorbar(im, ax=[ax_s, ax_a], shrink=0.8, label="F = Z_C+/Z_C0 (grey: infeasible)")
    order = "; ".join(f"{i}: {grid.label(cand.kind[k], cand.index[k])}" for i, k in enumerate(result.chosen, 1))
    fig.text(0.02, -0.02, f"chosen, by round: {order or 'none'}", fontsize=7, ha="left", va="top", wrap=True)
    return fig


def _missing(value):
    return value is None or value != value


def _summary(r, args):
    lines = [f"Constraint inference: {r['n_demonstrations']} demonstrations of {r['steps']} steps in {r['world']} "
             f"({r['n_states']} states, {r['n_actions']} actions)", ""]
    for i, ranking in enumerate(r["ranking"], start=1):
        accepted = i <= len(r["chosen"])
        head = f"round {i}" + ("" if accepted else "  (not accepted: stop rule)")
        lines.append(head)
        lines.append(f"  {'rank':>4}  {'candidate':<18}{'psi*':>7}{'F':>9}{'-log F':>9}{'exact gain':>12}")
        for row in ranking:
            psi = "" if _missing(row["psi"]) else f"{row['psi']:.3f}"
            mark = "  <- chosen" if row["chosen"] else ""
            lines.append(f"  {row['rank']:>4}  {row['label']:<18}{psi:>7}{row['F']:>9.4f}{row['neg_log_F']:>9.4f}"
                         f"{row['exact_gain']:>12.4f}{mark}")
        lines.append("")
    why = {"rounds": f"--rounds {r['rounds']} reached",
           "min-gain": f"the best remaining constraint gains less than --min-gain {r['min_gain']:g} nats "
                       "per demonstration",
           "no candidate left": "no feasible candidate left"}[r["stopped"]]
    lines.append(f"Stopped: {why}. Chosen constraints ({len(r['chosen'])}):")
    for row in r["chosen"]:
        psi = "" if _missing(row["psi"]) else f", psi* = {row['psi']:.3f}"
        lines.append(f"  round {row['round']}: {row['label']}{psi}, F = {row['F']:.4f}, "
                     f"exact gain {row['exact_gain']:.4f} nats/demo")
    lines += ["", "F: Z_C+/Z_C0 (Algorithm 4); exact gain: per-demonstration increase of the log-likelihood.",
              "wrote " + ", ".join(r["outputs"].values())]
    return "\n".join(lines)
