"""``mutual study power``: plan a replication of the chapter 5 study, in G*Power's words.

Three answers, in :func:`run_power`:

* ``--f F`` (with ``--m``, ``--rho``, ``--eps``, ``--alpha``, ``--power``, ``--n``): G*Power's "ANOVA:
  repeated measures, within factors" for one group: the power at each ``--n`` and the N reaching
  each ``--power`` (:func:`mutual.study.power.gpower_table`);
* ``--from-f F DF1 DF2`` (default: the thesis's ``F(2, 20) = 8.72``): the effect a reported F implies,
  with its bias corrected and its interval, and the N for each target (:func:`mutual.study.power.replication_plan`);
* unless ``--analytic-only`` (or ``--f``): the SIMULATED power of the omnibus test and the
  Learned-vs-Standard contrast from whole simulated cohorts, on Dask (an embedded LocalCluster by
  default, ``--scheduler ADDRESS`` or ``$MUTUAL_DASK_SCHEDULER`` for a running cluster, ``--inline``
  for no Dask at all).

Wiring: ``register(study_subparsers)`` adds the ``power`` command to the ``study`` group of the
``mutual`` command line (``EXTENSIONS = ("power",)`` in :mod:`.study`); ``main(argv)`` runs it alone
(``python -m mutual.cli.power``).
"""

import argparse
import sys

from .. import budget
from . import common

PROG = "mutual study power"
#: the keys of mutual.study.cohort_power.MIXES (spelled out: building the parser imports no numpy; a test checks)
MIX_NAMES = ("thesis", "mostly-standard", "mostly-gradual")
#: the largest N the G*Power tables search for a target power, and the --from-f design they accept
MAX_SIZES, MAX_N_ANALYTIC = 10_000, 100_000

DESCRIPTION = """\
Power and sample size of a one-way repeated-measures study, analytic (G*Power's "ANOVA: repeated
measures, within factors") and SIMULATED (whole cohorts of chapter 4's noisy supervisors run through
the chapter 5 study, on Dask).

  --f F [--m M --rho R --eps E --alpha A --power P --n N]   G*Power: power at N, and the N for power P
  --from-f F DF1 DF2                                        the effect a reported F implies, and the N
                                                            to replicate it (default: the thesis's 8.72 2 20)
  (without --analytic-only or --f)                          also the SIMULATED power at --n

Measured (figures/benchmarks.md, a shared 2.3 GHz 2-core machine): --f and --analytic-only 1.8-2.4 s
of CPU, nearly all of it importing scipy.stats and pandas, no JAX; the simulation about 3.5 s per cohort
of 11 participants per core plus 8-16 s to start a LocalCluster, and about 12 s wall (mostly imports and
loading the value functions; 4.9 s of CPU) once its cohorts are cached.

writes to --out:  power_gpower.csv (with --f) or power_plan.csv (--from-f); with the simulation also
                  power_simulated.csv, power_recommended.csv and power_curves.png
"""

EXAMPLE = """\
examples:
  mutual study power --f 0.25 --m 3 --rho 0.5 --power 0.95   # G*Power's a priori analysis: N = 43
  mutual study power --f 0.25 --m 3 --n 10 20 30 --eps 0.8   # power at given N, sphericity violated
  mutual study power --analytic-only                         # the plan from the thesis's F(2, 20) = 8.72
  mutual study power --n 6:40:2 11 --cohorts 60              # SIMULATED cohorts on a LocalCluster
  mutual study power --quick --n 6 8 --cohorts 4 --json      # a smoke test
  MUTUAL_DASK_SCHEDULER=tcp://host:8786 mutual study power --cohorts 1000   # on a running Dask cluster
"""

SIMULATION_OPTIONS = ("cohorts", "mix", "noise", "quick", "seed", "scheduler", "workers", "inline", "no_cache")


def _range_size(a, b, step):
    return (b - a) // step + 1 if a <= b else 0


def parse_sizes(tokens, cohorts=None, workers=1):
    """Sample sizes from tokens ``"6:40:2"`` (inclusive range, step optional), ``"11"`` or ``"6,8,11"``.

    The request is sized before anything is listed: the analytic power at each size
    (:func:`mutual.budget.sample_sizes`: an analytic N costs the same at any size), or ``cohorts`` simulated
    cohorts of the largest N on ``workers`` processes (:func:`mutual.budget.power_simulation`). A request
    beyond the memory or the time limit is refused with the estimate and ``--allow-large``."""
    ranges = []
    for token in tokens:
        for part in str(token).split(","):
            bits = part.strip().split(":")
            try:
                nums = [int(b) for b in bits]
            except ValueError:
                raise ValueError(f"--n: {part!r} is not a whole number or a range a:b[:step]") from None
            if len(nums) == 1:
                nums = [nums[0], nums[0], 1]
            elif len(nums) == 2:
                nums.append(1)
            if len(nums) != 3 or nums[2] <= 0 or nums[0] > nums[1]:
                raise ValueError(f"--n: {part!r} is not a range a:b[:step] with a <= b and step > 0")
            ranges.append((part.strip(), *nums))
    if not ranges:
        raise ValueError("--n: give at least one sample size")
    count = sum(_range_size(a, b, step) for _, a, b, step in ranges)
    top = max(b - (b - a) % step for _, a, b, step in ranges)
    budget.check(budget.sample_sizes(count, f"--n {' '.join(map(str, tokens))}") if cohorts is None else
                 budget.power_simulation(cohorts, top, workers))
    low = min(a for _, a, _, _ in ranges)
    if low < 3:
        raise ValueError(f"--n: sample sizes must be whole numbers >= 3, got {low}")
    return sorted({n for _, a, b, step in ranges for n in range(a, b + 1, step)})


def _whole(least, option):
    def parse(text):
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        return _checked_value(option, value, low=least, integer=True)
    return parse


def _real(option, low=None, high=None, low_open=False, high_open=False):
    def parse(text):
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        return _checked_value(option, value, low, high, low_open, high_open)
    return parse


def _checked_value(option, value, *bounds, **kind):
    """``value`` checked by :func:`mutual.inputs.check_number`, its error as argparse's (one line, the option named)."""
    from ..inputs import check_number
    try:
        return check_number(option, value, *bounds, **kind)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def add_arguments(parser):
    ana = parser.add_argument_group("analytic (G*Power: ANOVA, repeated measures, within factors)")
    ana.add_argument("--f", type=_real("--f", 0), metavar="F",
                     help="G*Power's effect size f (sd of the level means / sd of one measurement); selects the "
                          "G*Power analysis (analytic only)")
    ana.add_argument("--m", type=_whole(2, "--m"), default=None, metavar="M",
                     help="number of measurements (levels) per subject (default 3, the thesis's three safe sets)")
    ana.add_argument("--rho", type=_real("--rho", -1, 1, high_open=True), default=None, metavar="R",
                     help="correlation among the repeated measures, at least -1/(m-1) (default 0.5, as G*Power)")
    ana.add_argument("--eps", type=_real("--eps", 0, 1, low_open=True), default=1.0, metavar="E",
                     help="nonsphericity correction epsilon in [1/(m-1), 1] (default 1: sphericity)")
    ana.add_argument("--alpha", type=_real("--alpha", 0, 1, True, True), default=0.05,
                     help="significance level (default 0.05)")
    ana.add_argument("--power", type=_real("--power", 0, 1, True, True), nargs="+", default=[0.8, 0.9],
                     metavar="P", help="target power(s) for the sample size (default: 0.8 0.9)")
    ana.add_argument("--from-f", nargs=3, type=_real("--from-f", 0), default=None, metavar=("F", "DF1", "DF2"),
                     help="a reported one-way RM F and its degrees of freedom (default: the thesis's 8.72 2 20)")
    ana.add_argument("--analytic-only", action="store_true", help="no simulation")
    sim = parser.add_argument_group("simulation (SIMULATED cohorts with the chapter 5 model)")
    sim.add_argument("--n", nargs="+", default=None, metavar="N",
                     help="sample sizes: whole numbers or ranges a:b[:step] (simulation default: 6:40:2 11; "
                          "with --f: the power at each)")
    sim.add_argument("--cohorts", type=_whole(1, "--cohorts"), help="simulated cohorts per sample size (default 60)")
    sim.add_argument("--mix", choices=MIX_NAMES, help="mix of supervisor types (default: thesis)")
    sim.add_argument("--noise", type=_real("--noise", 0, low_open=True),
                     help="multiplier of the supervisors' judgement noise (default 1)")
    sim.add_argument("--quick", action="store_true", default=None,
                     help="quick grid, 15 scenes, 20-s trials (a smoke test)")
    sim.add_argument("--seed", type=_whole(0, "--seed"), help="root seed of the sweep (default 0)")
    dask = parser.add_argument_group("where the simulation runs")
    dask.add_argument("--scheduler", metavar="ADDRESS",
                      help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: $MUTUAL_DASK_SCHEDULER, "
                           "else an embedded LocalCluster)")
    dask.add_argument("--workers", type=_whole(1, "--workers"),
                      help="workers of the embedded LocalCluster (default: one per core)")
    dask.add_argument("--inline", action="store_true", default=None, help="run in this process, without Dask")
    dask.add_argument("--no-cache", action="store_true", default=None,
                      help="neither read nor write the per-cohort cache")
    common.add_output_options(parser)


def register(study_subparsers):
    """Add ``power`` to the ``mutual study`` command group."""
    parser = common.add_command(study_subparsers, "power", "power and sample size: G*Power's analytic and SIMULATED",
                                DESCRIPTION, EXAMPLE)
    add_arguments(parser)
    parser.set_defaults(handler=run_power, prog=parser.prog)
    return parser


def _checked(args):
    """Refuse options that do not go together, and fill in the defaults of the mode chosen."""
    from ..inputs import number_text
    given = [name for name in SIMULATION_OPTIONS if getattr(args, name) is not None]
    if args.f is not None:
        if args.from_f is not None:
            raise ValueError("--f and --from-f exclude each other: give G*Power's f, or a reported F to plan from")
        if given:
            raise ValueError(f"--{given[0].replace('_', '-')} is a simulation option; --f is G*Power's analytic "
                             "analysis (drop --f to simulate the chapter 5 study)")
        args.m = 3 if args.m is None else args.m
        args.rho = 0.5 if args.rho is None else args.rho
        if args.rho < -1 / (args.m - 1):
            raise ValueError(f"--rho {number_text(args.rho)}: below -1/(m-1) = {number_text(-1 / (args.m - 1))} for "
                             f"--m {args.m}, no covariance matrix has equal correlations")
    else:
        if args.rho is not None:
            raise ValueError("--rho goes with --f: the partial eta squared of a reported F already holds the correlation")
        args.from_f = args.from_f or [8.72, 2.0, 20.0]
        F, df1, df2 = args.from_f
        if not (df1.is_integer() and df2.is_integer() and df1 >= 1 and df2 >= 1):
            raise ValueError(f"--from-f: degrees of freedom must be whole numbers >= 1, got {number_text(df1)} "
                             f"{number_text(df2)}")
        if df1 + 1 > MAX_SIZES or df2 / df1 + 1 > MAX_N_ANALYTIC:
            raise ValueError(f"--from-f: F({df1:g}, {df2:g}) implies {df1 + 1:g} levels and {df2 / df1 + 1:g} subjects; "
                             f"at most {MAX_SIZES:,} levels and {MAX_N_ANALYTIC:,} subjects")
        if args.m is not None and args.m != int(df1) + 1:
            raise ValueError(f"--m {args.m}: F({int(df1)}, {int(df2)}) has {int(df1) + 1} levels")
        args.m = int(df1) + 1
    low = [p for p in args.power if p <= args.alpha]
    if low:
        raise ValueError(f"--power {number_text(low[0])}: a target power must exceed --alpha {number_text(args.alpha)} "
                         "(the power at zero effect)")
    if args.eps < 1 / (args.m - 1) - 1e-12:
        raise ValueError(f"--eps {number_text(args.eps)}: epsilon lies in [1/(m-1), 1] = "
                         f"[{number_text(1 / (args.m - 1))}, 1] for {args.m} measurements")
    defaults = {"cohorts": 60, "mix": "thesis", "noise": 1.0, "quick": False, "seed": 0, "inline": False,
                "no_cache": False}
    for name, value in defaults.items():
        setattr(args, name, value if getattr(args, name) is None else getattr(args, name))
    return args


def gpower(args):
    from ..study import gpower_table
    sizes = parse_sizes(args.n) if args.n else []
    return gpower_table(args.m, args.f, args.rho, args.eps, args.alpha, sizes, args.power, n_max=MAX_N_ANALYTIC)


def analytic(args):
    from ..study import effect_size_from_f, replication_plan
    F, df1, df2 = args.from_f
    est = effect_size_from_f(F, int(df1), int(df2))
    return est, replication_plan(F, int(df1), int(df2), targets=tuple(args.power), alpha=args.alpha,
                                 epsilon=args.eps, n_max=MAX_N_ANALYTIC)


def simulate(args):
    import os
    workers = 1 if args.inline else (args.workers or os.cpu_count() or 1)
    sizes = parse_sizes(args.n or ["6:40:2", "11"], args.cohorts, workers)
    from ..study import (CohortSetting, CohortTask, TaskCache, code_version, implied_effect, power_table,
                         recommendations, run_tasks, simulate_cohort, study_value_functions)

    setting = CohortSetting(mix=args.mix, noise_scale=args.noise,
                            **({"n_scenes": 15, "trial_seconds": 20.0, "quick_grid": True} if args.quick else {}))
    library, conservative = study_value_functions(quick=setting.quick_grid)
    tasks = [CohortTask(setting, c, max(sizes), args.seed) for c in range(args.cohorts)]
    cache = None if args.no_cache else TaskCache(code_version())
    cohorts, stats = run_tasks(simulate_cohort, tasks, shared=(library, conservative), cache=cache,
                               scheduler="inline" if args.inline else args.scheduler, workers=args.workers,
                               progress=not args.no_progress, desc="cohorts")
    table = power_table(cohorts, sizes, args.alpha)
    return setting, sizes, table, recommendations(table), implied_effect(cohorts), stats


def run_power(args):
    """The ``mutual study power`` command (``args`` from :func:`add_arguments`)."""
    try:
        args = _checked(args)
        if args.f is not None:
            table, sim = gpower(args), None
        else:
            table = analytic(args)
            sim = None if args.analytic_only else simulate(args)
    except budget.TooLarge:
        raise
    except ValueError as err:
        raise common.InputError(" ".join(str(err).split())) from None
    with common.output_set(args) as files:
        if args.f is not None:
            outputs = {"gpower": files.csv(table, "power_gpower.csv")}
        else:
            outputs = {"plan": files.csv(table[1], "power_plan.csv")}
        if sim is not None:
            setting, sizes, power, rec, effect, stats = sim
            outputs["simulated"] = files.csv(power.assign(setting=setting.label), "power_simulated.csv")
            outputs["recommended"] = files.csv(rec, "power_recommended.csv")
            outputs["figure"] = files.figure(_figure(power, setting, args), "power_curves.png")
    from .power_report import report_gpower, report_plan, report_simulated
    results, lines = report_gpower(args, table) if args.f is not None else report_plan(args, *table)
    if sim is not None:
        report_simulated(args, sim, results, lines)
    results["outputs"] = {k: str(v) for k, v in outputs.items()}
    lines.append("\nwrote " + ", ".join(results["outputs"].values()))
    common.report(args, "\n".join(lines), results)


def _figure(table, setting, args):
    common.use_agg()
    import matplotlib.pyplot as plt

    from ..study import finish_power_axes, plot_simulated_power
    from ..style import PALETTE
    fig, ax = plt.subplots(figsize=(6, 3.8))
    for test, colour in (("anova_gg", PALETTE["blue"]), ("tukey Standard-Learned", PALETTE["orange"]),
                         ("holm Standard-Learned", PALETTE["purple"])):
        plot_simulated_power(ax, table, test, test, colour)
    finish_power_axes(ax, f"SIMULATED power ({setting.label}, {args.cohorts} cohorts per N, 95% CI)",
                      sorted(table["n"].unique()))
    ax.legend(fontsize=7, loc="lower right")
    return fig


def main(argv=None):
    """``mutual study power`` on its own (``python -m mutual.cli.power``); returns the exit status."""
    parser = common.Parser(prog=PROG, description=DESCRIPTION, epilog=EXAMPLE,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(parser)
    parser.set_defaults(handler=run_power)
    return common.run(parser.parse_args(argv), PROG)


if __name__ == "__main__":
    sys.exit(main())
