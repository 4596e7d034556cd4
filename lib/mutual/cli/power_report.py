"""What ``mutual study power`` prints: the readable summary and the ``--json`` object of each answer
(G*Power's table, the plan from a reported F, the simulated power). A sample size that no N up to the
limit reaches is printed "not reached" (and is ``null`` in ``--json``), never NaN or ``38.000``."""

NOT_REACHED = "not reached"


def _missing(value):
    import pandas as pd
    return value is None or bool(pd.isna(value))


def _n(value):
    """A sample size as printed: a whole number, or "not reached"."""
    return NOT_REACHED if _missing(value) else str(int(value))


def _records(table):
    """Rows as plain values, a missing number (pandas NA or NaN) as None."""
    return [{k: (None if _missing(v) else v) for k, v in row.items()} for row in table.astype(object).to_dict("records")]


def report_gpower(args, table):
    """G*Power's "ANOVA: repeated measures, within factors" (one group) from ``gpower_table``."""
    head = (f"G*Power, ANOVA: repeated measures, within factors (one group): f = {args.f:g}, {args.m} measurements, "
            f"rho = {args.rho:g}, epsilon = {args.eps:g}, alpha = {args.alpha:g}")
    lines = [head, "", f"  {'':<22}{'N':>12}{'lambda':>10}{'df1':>7}{'df2':>9}{'F crit':>9}{'power':>8}"]
    for row in _records(table):
        what = "power at N" if row["kind"] == "power at N" else f"N for power {row['target']:g}"
        if row["n"] is None:
            lines.append(f"  {what:<22}{NOT_REACHED:>12}   (no N up to 100,000 reaches it"
                         + (": the effect is zero)" if args.f == 0 else ")"))
            continue
        lines.append(f"  {what:<22}{row['n']:>12}{row['lambda']:>10.4g}{row['df1']:>7.3g}{row['df2']:>9.4g}"
                     f"{row['F_crit']:>9.4g}{row['power']:>8.4f}")
    lines += ["", "  lambda = f^2 N m epsilon / (1 - rho), df1 = (m - 1) epsilon, df2 = (N - 1)(m - 1) epsilon "
                  "(Faul et al. 2007)"]
    results = {"command": "study power", "gpower": {
        "f": args.f, "m": args.m, "rho": args.rho, "eps": args.eps, "alpha": args.alpha, "power": list(args.power),
        "rows": _records(table)}}
    return results, lines


def report_plan(args, est, plan):
    """The plan from a reported F (``replication_plan``)."""
    shown = plan.astype(object).copy()
    for column in plan.columns:
        if column.startswith("N for"):
            shown[column] = [_n(v) for v in plan[column]]
        elif column != "estimate":
            shown[column] = [f"{v:.3f}" for v in plan[column]]
    eps = f", epsilon = {args.eps:g}" if args.eps != 1 else ""
    lines = [f"Analytic (G*Power RM convention{eps}) from F({est.df1}, {est.df2}) = {est.F:g}: {est!r}",
             shown.to_string(index=False)]
    results = {"command": "study power", "analytic": {
        "reported": {"F": est.F, "df1": est.df1, "df2": est.df2, "n": est.n, "m": est.m}, "eps": args.eps,
        "eta2p": est.eta2p, "eta2p_bias_corrected": est.eta2p_unbiased, "eta2p_ci95": est.eta2p_ci,
        "plan": _records(plan)}}
    return results, lines


def report_simulated(args, sim, results, lines):
    """The simulated power, appended to ``results`` and ``lines``."""
    setting, sizes, table, rec, effect, stats = sim
    results["simulated"] = {
        "SIMULATED": True, "setting": setting.__dict__, "n": sizes, "cohorts": args.cohorts,
        "power": table.to_dict("records"), "recommended": _records(rec),
        "implied_effect": {k: v for k, v in effect.items() if k != "cov"},
        "sweep": {"tasks": stats.tasks, "cached": stats.cached, "computed": stats.computed, "workers": stats.workers,
                  "where": stats.where, "seconds": stats.seconds}}
    wide = table[table["test"].isin(["anova_gg", "tukey Standard-Learned", "holm Standard-Learned"])].assign(
        cell=lambda d: [f"{p:.2f} [{lo:.2f}, {hi:.2f}]" for p, lo, hi in zip(d["power"], d["ci_low"], d["ci_high"])])
    shown = rec.astype(object).copy()
    for column in ("n", "n_conservative"):
        shown[column] = [_n(v) for v in rec[column]]
    workers = f"{stats.workers} worker{'s' if stats.workers != 1 else ''}"
    lines += [f"\nSIMULATED power ({setting.label}; {args.cohorts} cohorts per N; Wilson 95% intervals); "
              f"{stats.tasks} cohorts, {stats.cached} from the cache, {stats.seconds:.1f} s"
              + (f" on {workers} at {stats.where}" if stats.where else ""),
              wide.pivot(index="n", columns="test", values="cell").to_string(),
              "\nRecommended N (SIMULATED; not reached: beyond the largest N simulated):", shown.to_string(index=False),
              f"\nImplied effect (SIMULATED): eta2p = {effect['eta2p']:.3f}, epsilon = {effect['epsilon']:.3f}, "
              f"dz Standard-Learned = {effect['dz']['Standard-Learned']:.3f}"]
