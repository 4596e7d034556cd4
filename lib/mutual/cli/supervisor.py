"""``mutual supervisor fit``: a supervisor's safe set from their interventions (chapter 4).

Builds (or loads from the disk cache) the library of avoid value functions of the Dubins car
over ``w_max`` (eq. 4.3, Fig. 4.2; :func:`mutual.supervision.value_library`), then fits each
participant's interventions by maximum likelihood or MAP (eqs. 4.8-4.12, Sec. 4.4;
:func:`mutual.supervision.fit_supervisor`) and reports ``w_max``, ``mu``, ``sigma`` and the
avoidance level ``alpha = mu + k sigma`` of Sec. 4.5.
"""

import warnings

from . import common

#: ``--grid`` presets: name -> (half width, (nx, ny, ntheta), build time of the default library on 2 CPU cores)
GRIDS = {
    "quick": (8.0, (41, 41, 24), "about 10 s"),
    "full": (8.0, (101, 101, 64), "about 3 minutes"),
}


def _nodes(name):
    return " x ".join(str(n) for n in GRIDS[name][1]) + " nodes"


DEFAULT_W_MAXES = tuple(0.25 * k for k in range(1, 13))   # 0.25 ... 3.0 rad/s, the library of Fig. 4.2

DESCRIPTION = f"""\
Fit a supervisor's safe set to their interventions (Sec. 4.4). Each participant of
INTERVENTIONS.csv is fitted on their own (--participant picks one, --pool fits all rows together).

The model: the supervisor intervenes when the robot's state x reaches V_S(x) + w <= mu,
w ~ N(0, sigma^2), where V_S is the avoid value function of a Dubins car (speed --speed,
turn rate at most w_max) around a disk obstacle of radius --radius (eq. 4.3). The fit picks the
library member w_max and mu, sigma of maximum likelihood (eqs. 4.8-4.12); --prior map keeps
mu >= 0 and only members at least as cautious as the true robot (w_max = 1, Sec. 4.4).
The robot should avoid the supervisor's interventions at the level alpha = mu + k sigma, k = --level
(Sec. 4.5; k = 2 keeps clear of about 97.7% of interventions in expectation).

How long it takes: the value functions are computed once with hj-reachability (--method hj, the
thesis's method, the default) and cached on disk ($MUTUAL_CACHE_DIR, else ~/.cache/mutual); later
runs load them in about a second. Measured on 2 CPU cores for the default library of 12 members:
--grid quick: {_nodes('quick')}, {GRIDS['quick'][2]} the first time (coarse: for trying it out).
--grid full:  {_nodes('full')} (the chapter 4 notebook's grid; the default),
              {GRIDS['full'][2]} the first time.
--method closed-form: the exact avoid values of the undisturbed car at the grid's nodes instead of
              the HJ solve: about a second on either grid, nothing cached (for trying it out; the
              chapter 4 notebook compares the HJ values with it).
Both grids cover |x|, |y| <= 8 around the obstacle centre (in the units of x and y); every
intervention must lie inside.

writes to --out:  supervisor_fit.csv (one row per participant), supervisor_fit.png (each fitted
                  safe set with the interventions, rotated to a common heading)
"""

EXAMPLE = """\
example:
  mutual supervisor fit data/examples/interventions.csv --grid quick --prior map --level 2
"""


def register(subparsers):
    """Add ``mutual supervisor`` and its ``fit`` command."""
    commands = common.command_group(subparsers, "supervisor",
                                    "a supervisor's safe set from their interventions (chapter 4)",
                                    "Learn a supervisor's safe set from their interventions (chapter 4).")
    fit = common.add_command(commands, "fit", "fit w_max, mu, sigma and the avoidance level", DESCRIPTION, EXAMPLE)
    fit.add_argument("interventions", metavar="INTERVENTIONS.csv",
                     help="one row per intervention: participant, trial, time, x, y, theta[, obstacle_x, obstacle_y]")
    fit.add_argument("--grid", choices=sorted(GRIDS), default="full",
                     help=f"value-function grid: quick ({GRIDS['quick'][2]} the first time) or full "
                          f"(default; {GRIDS['full'][2]} the first time); cached afterwards")
    fit.add_argument("--method", choices=["hj", "closed-form"], default="hj",
                     help="hj: Hamilton-Jacobi reachability (the thesis's method, default); closed-form: the exact "
                          "values of the undisturbed car, about a second, for trying it out")
    fit.add_argument("--prior", choices=["mle", "map"], default="mle",
                     help="mle: maximum likelihood (eq. 4.12); map: conservative prior of Sec. 4.4 (default: mle)")
    fit.add_argument("--level", type=float, default=2.0, metavar="K",
                     help="report the avoidance level alpha = mu + K sigma (Sec. 4.5; default 2)")
    fit.add_argument("--participant", metavar="ID", help="fit only this participant")
    fit.add_argument("--pool", action="store_true", help="fit every row together as one supervisor")
    fit.add_argument("--w-max", metavar="W1,W2,...", default=",".join(f"{w:g}" for w in DEFAULT_W_MAXES),
                     help="the library's turn rates w_max in rad/s (default: 0.25, 0.5, ..., 3)")
    fit.add_argument("--radius", type=float, default=1.0, help="obstacle radius, in the units of x and y (default 1)")
    fit.add_argument("--speed", type=float, default=3.0, help="robot speed, units per second (default 3, eq. 5.1)")
    common.add_output_options(fit)
    fit.set_defaults(handler=run_fit, prog=fit.prog)


def _w_maxes(text):
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise common.InputError(f"--w-max {text!r}: expected comma-separated numbers, e.g. 0.5,1,2") from None
    if len(values) < 2:
        raise common.InputError(f"--w-max {text!r}: the library needs at least two members")
    return sorted(values)


def _groups(frame, args, path):
    """``{participant: (n, 3) states}`` to fit."""
    from ..supervision import intervention_states
    if args.pool:
        with common.about(path):
            return {"all": intervention_states(frame)}
    if args.participant is not None:
        frame = frame[frame["participant"].astype(str) == args.participant]
        if frame.empty:
            raise common.InputError(f"{path}: no intervention of participant {args.participant!r}")
    groups = {}
    for who, rows in frame.groupby("participant", sort=True):
        with common.about(path):
            groups[str(who)] = intervention_states(rows.reset_index(drop=True))
    return groups


def _at_edge(fit):
    """Whether the fit is the slowest or most agile member searched (the supervisor may lie beyond)."""
    import numpy as np
    boundary = getattr(fit, "boundary", "unknown")
    if boundary != "unknown":
        return boundary is not None
    searched = np.flatnonzero(fit.admissible)
    return bool(fit.index in (searched.min(), searched.max()))


def run_fit(args):
    import numpy as np
    import pandas as pd
    from ..supervision import read_interventions
    path = common.existing_file(args.interventions)
    if args.pool and args.participant is not None:
        raise common.InputError("--pool and --participant exclude each other")
    if not np.isfinite(args.level):
        raise common.InputError(f"--level {args.level}: must be a finite number")
    with common.about(path):
        frame = read_interventions(path)    # every column, every row, before any solve; names file, line, column
    half_width, shape, _ = GRIDS[args.grid]
    with common.about(path):
        from ..supervision import check_inside
        check_inside(frame, half_width, path)   # before any solve: names the line, in the file's coordinates
    groups = _groups(frame, args, path)
    w_maxes = _w_maxes(args.w_max)

    from ..supervision import GridSpec, fit_supervisor, value_library
    with common.about("--w-max/--radius/--speed"):
        library = value_library(w_maxes, args.radius, grid_spec=GridSpec(half_width, shape), speed=args.speed,
                                progress=not args.no_progress, method=args.method)
    rows, fits = [], {}
    for who, states in groups.items():
        with common.about(f"{path} (participant {who})"), warnings.catch_warnings():
            warnings.simplefilter("ignore")          # an edge of the library is reported in the table instead
            fit = fit_supervisor(library, states, prior=args.prior)
        fits[who] = (fit, states)
        rows.append({"participant": who, "n": fit.n, "w_max": fit.w_max, "mu": fit.mu, "sigma": fit.sigma,
                     "k": args.level, "alpha": fit.level(args.level), "coverage": fit.coverage(states, args.level),
                     "loglik": fit.loglik, "prior": args.prior, "at_library_edge": _at_edge(fit)})
    table = pd.DataFrame(rows)
    with common.output_set(args) as files:
        outputs = {"table": files.csv(table, "supervisor_fit.csv"),
                   "figure": files.figure(_figure(fits, args), "supervisor_fit.png")}
    results = {"command": "supervisor fit", "input": str(path), "grid": args.grid, "grid_shape": list(shape),
               "method": args.method,
               "library_w_max": w_maxes, "radius": args.radius, "speed": args.speed, "prior": args.prior,
               "level_k": args.level, "fits": rows, "outputs": {k: str(v) for k, v in outputs.items()}}
    common.report(args, _summary(results), results)


def _figure(fits, args):
    """One panel per participant (at most 12): the fitted V at a common heading, its mu and alpha level
    sets, and the interventions rotated about the obstacle centre to that heading (V is invariant)."""
    common.use_agg()
    import matplotlib.pyplot as plt
    import numpy as np
    from ..style import PALETTE
    from ..supervision import rotate_to_heading
    shown = list(fits.items())[:12]
    cols = min(len(shown), 4)
    rows = -(-len(shown) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.0 * cols, 3.2 * rows), squeeze=False, layout="constrained")
    slices = [fit.value_fn.theta_slice(0.0, resolution=161) for _, (fit, _) in shown]
    levels = np.linspace(min(np.nanmin(v) for _, _, v in slices), max(np.nanmax(v) for _, _, v in slices), 21)
    for ax, (who, (fit, states)), (xs, ys, v) in zip(axes.ravel(), shown, slices):
        p = rotate_to_heading(states, 0.0)
        half = float(min(fit.value_fn.grid_spec.half_width, max(4 * args.radius, 1.3 * np.abs(p[:, :2]).max())))
        image = ax.contourf(xs, ys, v, levels=levels, cmap="viridis")
        ax.contour(xs, ys, v, levels=[fit.mu], colors="white", linewidths=1.2)
        ax.contour(xs, ys, v, levels=[fit.level(args.level)], colors=PALETTE["orange"], linewidths=1.2)
        ax.plot(p[:, 0], p[:, 1], "o", ms=3, mfc="none", mec=PALETTE["vermillion"])
        ax.add_patch(plt.Circle((0, 0), args.radius, color="black"))
        ax.set_title(f"{who}\nw_max = {fit.w_max:g} rad/s, mu = {fit.mu:.2f}, sigma = {fit.sigma:.2f}", fontsize=7)
        ax.set(xlim=(-half, half), ylim=(-half, half), aspect="equal", xlabel="x (robot heading +x)", ylabel="y")
    fig.colorbar(image, ax=axes.ravel().tolist(), shrink=0.8, label="fitted V (units of x, y)")
    for ax in axes.ravel()[len(shown):]:
        ax.axis("off")
    fig.suptitle(f"white: mu level; orange: alpha = mu + {args.level:g} sigma; red: interventions "
                 "(rotated about the obstacle to a common heading)", fontsize=7)
    return fig


def _summary(r):
    lines = [f"Supervisor safe sets from {r['input']} ({r['prior'].upper()}, {r['method']} values on the "
             f"{r['grid']} grid, "
             f"library w_max = {', '.join(f'{w:g}' for w in r['library_w_max'])} rad/s)", ""]
    k = r["level_k"]
    lines.append(f"  {'participant':<14}{'n':>5}{'w_max':>8}{'mu':>9}{'sigma':>9}{f'alpha (k={k:g})':>15}"
                 f"{'covered':>9}")
    for f in r["fits"]:
        lines.append(f"  {f['participant']:<14}{f['n']:>5}{f['w_max']:>8.4g}{f['mu']:>9.4f}{f['sigma']:>9.4f}"
                     f"{f['alpha']:>15.4f}{f['coverage']:>9.1%}" + ("  *" if f["at_library_edge"] else ""))
    lines += ["", "  alpha = mu + k sigma: the level at which the robot should start avoiding (Sec. 4.5);",
              "  covered: share of the participant's interventions at or below alpha."]
    if any(f["at_library_edge"] for f in r["fits"]):
        lines.append("  *: the fit is the slowest or most agile member searched (with --prior map the most agile is "
                     "the true robot's w_max = 1); the supervisor may lie beyond it (widen --w-max).")
    lines += ["", "wrote " + ", ".join(r["outputs"].values())]
    return "\n".join(lines)
