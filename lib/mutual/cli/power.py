"""``mutual study power``: plan a replication of the chapter 5 study (issue 16).

Analytic power from the thesis's reported F (G*Power's repeated-measures convention) and the
SIMULATED power of the omnibus test and the Learned-vs-Standard contrast from whole simulated
cohorts, on Dask: an embedded LocalCluster by default, ``--scheduler ADDRESS`` (or
``$MUTUAL_DASK_SCHEDULER``) for a running cluster, ``--inline`` for no Dask at all::

    mutual study power --n 6:40:2 11 --cohorts 60
    mutual study power --quick --n 6 8 --cohorts 4 --json
    mutual study power --scheduler tcp://10.0.0.5:8786 --cohorts 1000
    mutual study power --analytic-only --from-f 8.72 2 20

Wiring: ``register(study_subparsers)`` adds the ``power`` command to the ``study`` group of the
``mutual`` command line (``EXTENSIONS = ("power",)`` in :mod:`.study`); ``main(argv)`` runs it alone
(``python -m mutual.cli.power``). Outputs to ``--out``: ``power_plan.csv`` (analytic) and, with the
simulation, ``power_simulated.csv``, ``power_recommended.csv`` and ``power_curves.png``.
"""

import argparse
import sys

from . import common

PROG = "mutual study power"
#: the keys of mutual.study.cohort_power.MIXES (spelled out: building the parser imports no numpy; a test checks)
MIX_NAMES = ("thesis", "mostly-standard", "mostly-gradual")

EXAMPLE = """\
examples:
  mutual study power --analytic-only                         # the plan from the thesis's F(2, 20) = 8.72
  mutual study power --n 6:40:2 11 --cohorts 60              # SIMULATED cohorts on a LocalCluster
  mutual study power --quick --n 6 8 --cohorts 4 --json      # a smoke test
  MUTUAL_DASK_SCHEDULER=tcp://host:8786 mutual study power --cohorts 1000   # on a running Dask cluster
"""


def parse_sizes(tokens):
    """Sample sizes from tokens ``"6:40:2"`` (inclusive range, step optional), ``"11"`` or ``"6,8,11"``."""
    sizes = set()
    for token in tokens:
        for part in str(token).split(","):
            bits = part.strip().split(":")
            try:
                nums = [int(b) for b in bits]
            except ValueError:
                raise ValueError(f"--n: {part!r} is not an integer or a range a:b[:step]") from None
            if len(nums) == 1:
                sizes.add(nums[0])
            elif len(nums) in (2, 3) and (len(nums) == 2 or nums[2] > 0) and nums[0] <= nums[1]:
                sizes.update(range(nums[0], nums[1] + 1, nums[2] if len(nums) == 3 else 1))
            else:
                raise ValueError(f"--n: {part!r} is not a range a:b[:step] with a <= b and step > 0")
    if not sizes or min(sizes) < 3:
        raise ValueError(f"--n: sample sizes must be integers >= 3, got {sorted(sizes)}")
    return sorted(sizes)


def add_arguments(parser):
    sim = parser.add_argument_group("simulation (SIMULATED cohorts with the chapter 5 model)")
    sim.add_argument("--n", nargs="+", default=["6:40:2", "11"], metavar="N",
                     help="analysed sample sizes: integers or ranges a:b[:step] (default: 6:40:2 11)")
    sim.add_argument("--cohorts", type=int, default=60, help="simulated cohorts per sample size (default 60)")
    sim.add_argument("--mix", choices=MIX_NAMES, default="thesis", help="mix of supervisor types (default: thesis)")
    sim.add_argument("--noise", type=float, default=1.0, help="multiplier of the supervisors' judgement noise")
    sim.add_argument("--quick", action="store_true", help="quick grid, 15 scenes, 20-s trials (a smoke test)")
    sim.add_argument("--seed", type=int, default=0, help="root seed of the sweep (default 0)")
    sim.add_argument("--alpha", type=float, default=0.05, help="significance level (default 0.05)")
    dask = parser.add_argument_group("where it runs")
    dask.add_argument("--scheduler", metavar="ADDRESS",
                      help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: $MUTUAL_DASK_SCHEDULER, "
                           "else an embedded LocalCluster)")
    dask.add_argument("--workers", type=int, help="workers of the embedded LocalCluster (default: one per core)")
    dask.add_argument("--inline", action="store_true", help="run in this process, without Dask")
    dask.add_argument("--no-cache", action="store_true", help="neither read nor write the per-cohort cache")
    ana = parser.add_argument_group("analytic")
    ana.add_argument("--analytic-only", action="store_true", help="only the analytic plan from the reported F")
    ana.add_argument("--from-f", nargs=3, type=float, default=[8.72, 2, 20], metavar=("F", "DF1", "DF2"),
                     help="the reported one-way RM F and its degrees of freedom (default: the thesis's 8.72 2 20)")
    common.add_output_options(parser)


def register(study_subparsers):
    """Add ``power`` to the ``mutual study`` command group."""
    parser = study_subparsers.add_parser("power", help="plan a replication: analytic and SIMULATED power",
                                         description=__doc__.split("\n\n")[1], epilog=EXAMPLE,
                                         formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(parser)
    parser.set_defaults(handler=run_power, prog=parser.prog)
    return parser


def analytic(args):
    from ..study.power import effect_size_from_f, replication_plan

    F, df1, df2 = args.from_f
    if not (float(df1).is_integer() and float(df2).is_integer()):
        raise ValueError(f"--from-f: degrees of freedom must be integers, got {df1:g} {df2:g}")
    return effect_size_from_f(F, int(df1), int(df2)), replication_plan(F, int(df1), int(df2), alpha=args.alpha)


def simulate(args):
    from ..study import cohort, cohort_power as cp, power_summary as ps, sweep

    if args.cohorts < 1:
        raise ValueError(f"--cohorts must be a positive integer, got {args.cohorts}")
    sizes = parse_sizes(args.n)
    setting = cp.CohortSetting(mix=args.mix, noise_scale=args.noise,
                               **({"n_scenes": 15, "trial_seconds": 20.0, "quick_grid": True} if args.quick else {}))
    library, conservative = cohort.study_value_functions(quick=setting.quick_grid)
    tasks = [cp.CohortTask(setting, c, max(sizes), args.seed) for c in range(args.cohorts)]
    cache = None if args.no_cache else sweep.TaskCache(cp.code_version())
    cohorts, stats = sweep.run_tasks(cp.simulate_cohort, tasks, shared=(library, conservative), cache=cache,
                                     scheduler="inline" if args.inline else args.scheduler, workers=args.workers,
                                     progress=not args.no_progress, desc="cohorts")
    table = ps.power_table(cohorts, sizes, args.alpha)
    return setting, sizes, table, ps.recommendations(table), ps.implied_effect(cohorts), stats


def run_power(args):
    """The ``mutual study power`` command (``args`` from :func:`add_arguments`)."""
    try:
        est, plan = analytic(args)
        sim = None if args.analytic_only else simulate(args)
    except ValueError as err:
        raise common.InputError(" ".join(str(err).split())) from None
    outputs = {"plan": common.write_csv(plan, common.output_path(args, "power_plan.csv"))}
    results = {"command": "study power", "analytic": {
        "reported": {"F": est.F, "df1": est.df1, "df2": est.df2, "n": est.n, "m": est.m},
        "eta2p": est.eta2p, "eta2p_bias_corrected": est.eta2p_unbiased, "eta2p_ci95": est.eta2p_ci,
        "plan": plan.to_dict("records")}}
    lines = [f"Analytic (G*Power RM convention) from F({est.df1}, {est.df2}) = {est.F:g}: {est!r}",
             plan.to_string(index=False, float_format=lambda v: f"{v:.3f}")]
    if sim is not None:
        setting, sizes, table, rec, effect, stats = sim
        outputs["simulated"] = common.write_csv(table.assign(setting=setting.label),
                                                common.output_path(args, "power_simulated.csv"))
        outputs["recommended"] = common.write_csv(rec, common.output_path(args, "power_recommended.csv"))
        outputs["figure"] = common.save_figure(_figure(table, setting, args), common.output_path(args, "power_curves.png"))
        results["simulated"] = {
            "SIMULATED": True, "setting": setting.__dict__, "n": sizes, "cohorts": args.cohorts,
            "power": table.to_dict("records"), "recommended": rec.to_dict("records"),
            "implied_effect": {k: v for k, v in effect.items() if k != "cov"},
            "sweep": {"tasks": stats.tasks, "cached": stats.cached, "computed": stats.computed, "workers": stats.workers,
                      "where": stats.where, "seconds": stats.seconds}}
        wide = table[table["test"].isin(["anova_gg", "tukey Standard-Learned", "holm Standard-Learned"])].assign(
            cell=lambda d: [f"{p:.2f} [{lo:.2f}, {hi:.2f}]" for p, lo, hi in zip(d["power"], d["ci_low"], d["ci_high"])])
        lines += [f"\nSIMULATED power ({setting.label}; {args.cohorts} cohorts per N; Wilson 95% intervals); "
                  f"{stats.tasks} cohorts, {stats.cached} from the cache, {stats.seconds:.1f} s"
                  + (f" on {stats.workers} workers at {stats.where}" if stats.where else ""),
                  wide.pivot(index="n", columns="test", values="cell").to_string(),
                  "\nRecommended N (SIMULATED):", rec.to_string(index=False),
                  f"\nImplied effect (SIMULATED): eta2p = {effect['eta2p']:.3f}, epsilon = {effect['epsilon']:.3f}, "
                  f"dz Standard-Learned = {effect['dz']['Standard-Learned']:.3f}"]
    results["outputs"] = {k: str(v) for k, v in outputs.items()}
    lines.append("\nwrote " + ", ".join(results["outputs"].values()))
    common.report(args, "\n".join(lines), results)


def _figure(table, setting, args):
    common.use_agg()
    import matplotlib.pyplot as plt

    from ..study import power_plots
    from ..style import PALETTE
    fig, ax = plt.subplots(figsize=(6, 3.8))
    for test, colour in (("anova_gg", PALETTE["blue"]), ("tukey Standard-Learned", PALETTE["orange"]),
                         ("holm Standard-Learned", PALETTE["purple"])):
        power_plots.plot_simulated_power(ax, table, test, test, colour)
    power_plots.finish_power_axes(ax, f"SIMULATED power ({setting.label}, {args.cohorts} cohorts per N, 95% CI)",
                                  sorted(table["n"].unique()))
    ax.legend(fontsize=7, loc="lower right")
    return fig


def main(argv=None):
    """``mutual study power`` on its own (``python -m mutual.cli.power``); returns the exit status."""
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[1], epilog=EXAMPLE,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(parser)
    parser.set_defaults(handler=run_power)
    return common.run(parser.parse_args(argv), PROG)


if __name__ == "__main__":
    sys.exit(main())
