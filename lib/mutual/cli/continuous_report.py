"""What ``mutual constraints infer-continuous`` prints and writes: the rounds, the accepted constraints with
their gains and intervals, the refused one, the notes (the points model), or chapters 2-3's ranking by F
with chance thresholds (the cells model)."""

from . import common


def report_inference(args, run, traj_path, system_path):
    """Write the ranking, the accepted constraints and the figure as a set, and print the summary (or JSON)."""
    from ..constraints.continuous import inference_figure
    common.use_agg()
    table, chosen = run.ranking(), run.chosen()
    with common.output_set(args) as files:
        outputs = {"ranking": files.csv(table, "continuous_ranking.csv"),
                   "chosen": files.csv(chosen, "continuous_chosen.csv"),
                   "figure": files.figure(inference_figure(run), "continuous_constraints.png")}
    problem = run.problem
    results = {"command": "constraints infer-continuous", "input": str(traj_path), "system": str(system_path),
               "model": args.model, "dynamics": problem.system.spec, "dynamics_file": problem.system.file, "dt": problem.dt,
               "cells": list(problem.grid.shape), "n_states": problem.grid.n_cells, "n_controls": problem.n_actions,
               "scheme": problem.scheme, "rounds": args.rounds,
               "stopped": run.stop, "chosen": chosen.to_dict(orient="records"),
               "ranking": [t.head(args.top).to_dict(orient="records") for t in _round_tables(run, table)],
               "seconds": run.seconds, "outputs": {k: str(v) for k, v in outputs.items()}}
    if args.model == "points":
        data = run.data
        results.update(n_demonstrations=data.n, steps=data.steps, weights=_weights(run), notes=run.notes,
                       best_rejected=run.best_rejected(), controls_inferred=data.inferred)
        summary = _summary_points(results)
    else:
        mapped = run.mapped
        results.update(n_demonstrations=mapped.demos.n, steps=mapped.demos.steps, thresholds=args.thresholds,
                       controls={"recorded_snapped": mapped.snapped, "inferred": mapped.inferred,
                                 "inferred_mean_miss_cells": mapped.miss, "zero_probability_steps_added": mapped.added},
                       n_candidates=len(run.candidates), thresholds_raised_by_lemma=run.candidates.raised)
        summary = _summary_cells(results, mapped.notes())
    common.report(args, summary, results)


def code_note(file):
    """`` (its code ran from FILE)`` for a user's dynamics (the system file's ``module:function``), else nothing."""
    return f" (its code ran from {file})" if file else ""


def _weights(run):
    """The reward's weights of every round as {"q": [...], "c": [...], "Q": [...]} (a fixed temperature:
    the file's weights divided by it)."""
    from ..constraints.continuous import file_weights
    p = run.problem
    d, m = p.grid.ndim, p.controls.shape[1]
    out = []
    for w in run.weights:
        w = file_weights(p, w) if hasattr(w, "__float__") and not hasattr(w, "__len__") else w
        out.append({"q": [float(v) for v in w[:d]], "c": [float(v) for v in w[d:d + m]], "Q": [float(v) for v in w[d + m:]]})
    return out


def _round_tables(run, table):
    return [table[table["round"] == r] for r in sorted(table["round"].unique())] if len(table) else []


def _header(r):
    return (f"Constraints from {r['n_demonstrations']} continuous demonstrations of {r['steps']} steps of "
            f"{r['dt']:g} s ({r['input']}), system {r['dynamics']!r}{code_note(r['dynamics_file'])} on {' x '.join(map(str, r['cells']))} cells, "
            f"{r['n_controls']} controls, {r['scheme']} scheme, model {r['model']!r}")


def _rankings(rankings, width, columns, flag, after_round):
    """Each round's ranking as text lines: rank, the constraint in ``width`` characters, then ``columns``
    (heading, key, width, format), and ``  <- flag`` on the row whose ``flag`` is set; ``after_round(i)``
    follows the round's heading."""
    lines = []
    for i, ranking in enumerate(rankings, start=1):
        lines.append(f"round {i}{after_round(i)}")
        lines.append(f"  {'rank':>4}  {'constraint':<{width}}" + "".join(f"{h:>{w}}" for h, _, w, _ in columns))
        for row in ranking:
            mark = f"  <- {flag}" if row[flag] else ""
            lines.append(f"  {row['rank']:>4}  {row['constraint'][:width - 1]:<{width}}"
                         + "".join(f"{row[key]:>{w}{fmt}}" for _, key, w, fmt in columns) + mark)
        lines.append("")
    return lines


def _summary_points(r):
    lines = [_header(r), "Reward weights per round (maximum likelihood unless fixed; running q per coordinate, "
                         "c per control, terminal Q per coordinate, in the file's units divided by the temperature):"]
    lines += [f"  round {i}: " + ", ".join(f"{k} = [{', '.join(f'{v:.3g}' for v in vals)}]" for k, vals in w.items())
              for i, w in enumerate(r["weights"], start=1)] + [""]
    lines += _rankings(r["ranking"], 52, [("gain", "gain", 10, ".3f"), ("per demo", "gain_per_demo", 10, ".3f"),
                                          ("F", "F", 8, ".3f")], "accepted", lambda i: "")
    why = {"rounds": f"--rounds {r['rounds']} reached", "no candidate": "no candidate left",
           "min_gain": "the best candidate gains too little"}[r["stopped"]]
    lines.append(f"Stopped: {why}. Accepted constraints ({len(r['chosen'])}):")
    for row in r["chosen"]:
        lines.append(f"  round {row['round']}: {row['constraint']}, exact gain {row['gain_refit']:.2f} nats "
                     f"({row['gain_refit'] / r['n_demonstrations']:.3f} per demonstration; needed "
                     f"{row['needed']:.2f}); {row['interval_of']} in [{row['interval_low']:.4g}, "
                     f"{row['interval_high']:.4g}] (likelihood within a factor 20 of the best)")
    rejected = r["best_rejected"]
    if rejected:
        lines.append(f"  refused: {rejected['constraint']}, exact gain {rejected['gain_refit']:.2f} nats "
                     f"({rejected['gain_refit'] / r['n_demonstrations']:.3f} per demonstration; needed "
                     f"{rejected['needed']:.2f})")
    lines += [f"Note: {note}" for note in r["notes"]]
    lines += ["", "gain: the exact increase of the demonstrations' log-likelihood (nats, all demonstrations); "
                  "F = exp(-gain per demonstration): the model's share of trajectories that respect it",
              "wrote " + ", ".join(r["outputs"].values())]
    return "\n".join(lines)


def _summary_cells(r, notes):
    lines = [_header(r), f"Mapping: {notes}", f"{r['n_candidates']} candidates ({r['thresholds']} thresholds; "
                                              f"{r['thresholds_raised_by_lemma']} raised above eq. 3.3)", ""]
    lines += _rankings(r["ranking"], 46, [("psi", "psi", 7, ".3f"), ("F", "F", 11, ".4g"), ("-log F", "neg_log_F", 9, ".4f"),
                                          ("exact gain", "exact_gain", 12, ".4f")], "chosen",
                       lambda i: "" if i <= len(r["chosen"]) else "  (not accepted: stop rule)")
    why = {"rounds": f"--rounds {r['rounds']} reached",
           "min_gain": "the best remaining constraint gains less than --min-gain nats per demonstration",
           "no feasible candidate": "no feasible candidate left"}[r["stopped"]]
    lines.append(f"Stopped: {why}. Chosen constraints ({len(r['chosen'])}):")
    for row in r["chosen"]:
        lines.append(f"  round {row['round']}: {row['constraint']} (psi = {row['psi']:.3f}), F = {row['F']:.4g}, "
                     f"exact gain {row['exact_gain']:.4f} nats/demo")
    lines += ["", "F: Z_C+/Z_C0 (Algorithm 4); exact gain: per-demonstration increase of the log-likelihood.",
              "wrote " + ", ".join(r["outputs"].values())]
    return "\n".join(lines)
