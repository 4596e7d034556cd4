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
``mutual`` command line; ``main(argv)`` runs it alone (``python -m mutual.cli.power``).
"""

import argparse
import json
import sys

import numpy as np

PROG = "mutual study power"


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
    from ..study.cohort_power import MIXES

    sim = parser.add_argument_group("simulation (SIMULATED cohorts with the chapter 5 model)")
    sim.add_argument("--n", nargs="+", default=["6:40:2", "11"], metavar="N",
                     help="analysed sample sizes: integers or ranges a:b[:step] (default: 6:40:2 11)")
    sim.add_argument("--cohorts", type=int, default=60, help="simulated cohorts per sample size (default 60)")
    sim.add_argument("--mix", choices=sorted(MIXES), default="thesis", help="mix of supervisor types (default: thesis)")
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
    dask.add_argument("--no-progress", action="store_true", help="no progress bar")
    ana = parser.add_argument_group("analytic")
    ana.add_argument("--analytic-only", action="store_true", help="only the analytic plan from the reported F")
    ana.add_argument("--from-f", nargs=3, type=float, default=[8.72, 2, 20], metavar=("F", "DF1", "DF2"),
                     help="the reported one-way RM F and its degrees of freedom (default: the thesis's 8.72 2 20)")
    parser.add_argument("--json", action="store_true", help="print one JSON document instead of tables")


def register(study_subparsers):
    """Add ``power`` to the ``mutual study`` command group."""
    parser = study_subparsers.add_parser("power", help="plan a replication: analytic and simulated power",
                                         description=__doc__.split("\n\n")[1])
    add_arguments(parser)
    parser.set_defaults(func=run)
    return parser


def _plain(value):
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return None if not np.isfinite(value) else float(value)
    return value


def analytic(args):
    from ..study.power import effect_size_from_f, replication_plan

    F, df1, df2 = args.from_f
    if not (float(df1).is_integer() and float(df2).is_integer()):
        raise ValueError(f"--from-f: degrees of freedom must be integers, got {df1:g} {df2:g}")
    est = effect_size_from_f(F, int(df1), int(df2))
    plan = replication_plan(F, int(df1), int(df2), alpha=args.alpha)
    return est, plan


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


def run(args):
    """Run the command from parsed ``args``; returns the exit status."""
    try:
        est, plan = analytic(args)
        sim = None if args.analytic_only else simulate(args)
    except ValueError as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return 2
    if args.json:
        doc = {"analytic": {"reported": {"F": est.F, "df1": est.df1, "df2": est.df2, "n": est.n, "m": est.m},
                            "eta2p": est.eta2p, "eta2p_bias_corrected": est.eta2p_unbiased, "eta2p_ci95": est.eta2p_ci,
                            "plan": plan.to_dict("records")}}
        if sim is not None:
            setting, sizes, table, rec, effect, stats = sim
            doc["simulated"] = {"SIMULATED": True, "setting": setting.__dict__, "n": sizes, "cohorts": args.cohorts,
                                "power": table.to_dict("records"), "recommended": rec.to_dict("records"),
                                "implied_effect": {k: v for k, v in effect.items() if k != "cov"},
                                "sweep": {"tasks": stats.tasks, "cached": stats.cached, "computed": stats.computed,
                                          "workers": stats.workers, "where": stats.where, "seconds": stats.seconds}}
        print(json.dumps(_plain(doc), indent=1))
        return 0
    print(f"Analytic (G*Power RM convention) from F({est.df1}, {est.df2}) = {est.F:g}: {est!r}")
    print(plan.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    if sim is not None:
        setting, sizes, table, rec, effect, stats = sim
        print(f"\nSIMULATED power ({setting.label}; {args.cohorts} cohorts per N; Wilson 95% intervals); "
              f"{stats.tasks} cohorts, {stats.cached} from the cache, {stats.seconds:.1f} s"
              + (f" on {stats.workers} workers at {stats.where}" if stats.where else ""))
        wide = table[table["test"].isin(["anova_gg", "tukey Standard-Learned", "holm Standard-Learned"])].assign(
            cell=lambda d: [f"{p:.2f} [{lo:.2f}, {hi:.2f}]" for p, lo, hi in zip(d["power"], d["ci_low"], d["ci_high"])])
        print(wide.pivot(index="n", columns="test", values="cell").to_string())
        print("\nRecommended N (SIMULATED):")
        print(rec.to_string(index=False))
        print(f"\nImplied effect (SIMULATED): eta2p = {effect['eta2p']:.3f}, epsilon = {effect['epsilon']:.3f}, "
              f"dz Standard-Learned = {effect['dz']['Standard-Learned']:.3f}")
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[1])
    add_arguments(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
