"""``mutual constraints infer-continuous`` and ``mutual constraints simulate``.

``infer-continuous`` reads recorded trajectories of a continuous system and its system file and
infers the constraints the demonstrations respect (:mod:`mutual.constraints.continuous`): by default
the exact likelihood of the continuous demonstrations with candidates as continuous parameters
(``--model points``), or chapters 2-3's greedy inference on the discretized MDP (``--model cells``).
``simulate`` writes demonstrations to try it with: of a continuous system (by a demonstrator on the
true dynamics that respects --hidden constraints) or of a gridworld (chapter 3's Boltzmann agent).
Heavy libraries are imported inside the commands.
"""

from contextlib import contextmanager

from .. import budget
from . import common, continuous_sizes
from .continuous_report import code_note, report_inference

DEFAULT_ROUNDS, DEFAULT_TOP = 5, 5
MIN_GAIN = {"points": 0.693, "cells": 0.1}   # inference.MIN_GAIN = log 2 (no numpy here; a test checks)
FAMILIES = ("bound", "disk", "box", "cell")   # mutual.constraints.continuous.candidates.FAMILIES (no numpy here; a test checks)

INFER_DESCRIPTION = f"""\
Constraints from continuous demonstrations (an extension of chapters 2-3; Section 3.4's next step).

The system file gives the dynamics, a box over the state space cut into cells, a control set, a
time step and the demonstrator's task (a quadratic reward).

--model points (default): the likelihood of the continuous demonstrations of the deterministic system
is exact up to the partition function, which is computed on the grid's cells as points (the
demonstrator knows its state: chance thresholds are psi = 0 per point, none is raised or dropped).
For a tightening the demonstrations satisfy, the gain is -log F at their starts (eq. 2.25, exact for
deterministic dynamics). Each round proposes the most likely member of each family -- "bound": the
tightest bound the demonstrations satisfy, per coordinate and side; "disk" / "box": the largest
obstacle in the plane of two coordinates that no demonstration enters, at the most likely centre,
where the demonstrations pass it on more than one side -- and accepts the best if it raises the exact
log-likelihood by --min-gain nats per demonstration (default log 2 = {MIN_GAIN["points"]}: more than half
of the model's trajectories would cross it) and by log(K / 0.05) in all. Each accepted constraint comes with the interval of
values whose likelihood is within a factor 20 of the best. The temperature is fitted by maximum
likelihood, as are the weights of its features (the goal stays the file's); --temperature file or NUMBER
keeps the file's reward at that temperature.

--model cells: the dynamics are discretized into a tabular MDP (Monte Carlo within cells, Stocking et
al. 2021, or barycentric interpolation), the recordings mapped onto it, and chapters 2-3's candidates
-- "bound" (every cell edge), "disk", "box", "cell" -- ranked by F = Z_C+ / Z_C0 (Algorithm 4) with
chance thresholds set per cell (--thresholds lemma: Lemma 3.2.1; eq3.3); it stops before a constraint
whose -log F is below --min-gain (default {MIN_GAIN["cells"]}). Discretization runs here for small grids and on
Dask for large ones (--scheduler ADDRESS / $MUTUAL_DASK_SCHEDULER; --inline never uses Dask).

TRAJ.csv: demo, t, one column per state coordinate, optionally one per control. SYSTEM.toml: system,
[parameters], [state], [control], [time], [discretization], [reward], [candidates], [simulate].
Formats: data/README.md.

writes to --out:  continuous_ranking.csv (every candidate of every round in its units, with its gain),
                  continuous_chosen.csv (the accepted constraints; points: with their intervals),
                  continuous_constraints.png (the demonstrations with the inferred regions by round)
"""

INFER_EXAMPLE = """\
examples:
  mutual constraints infer-continuous data/examples/pendulum_trajectories.csv --system data/examples/pendulum.toml
  mutual constraints simulate --system data/examples/pendulum.toml --out mine/
  mutual constraints infer-continuous mine/trajectories.csv --system data/examples/pendulum.toml --json
"""

SIMULATE_DESCRIPTION = """\
Write demonstrations to try constraint inference on, in the documented formats (data/README.md).

--system SYSTEM.toml: trajectories of the continuous system (trajectories.csv), from the start in
[simulate] (+- spread), by a demonstrator acting on the TRUE continuous dynamics that never enters a
--hidden region: "soft", a Boltzmann (maximum-causal-entropy) demonstrator solved on a finer grid
([simulate] fine_cells), or "mppi", sampled trajectory optimisation. Hidden constraints:
"NAME <= VALUE", "NAME >= VALUE", "disk X Y R", "box XMIN XMAX YMIN YMAX" (in [candidates] plane).

--world WORLD.toml: demonstrations of chapter 3's gridworld (demonstrations.csv) from its Boltzmann
agent under --hidden constraints "cell COL ROW" (optionally "psi P", default 0: forbidden) and
"action NAME" (E, NE, N, NW, W, SW, S, SE).
"""

SIMULATE_EXAMPLE = """\
examples:
  mutual constraints simulate --system data/examples/pendulum.toml --hidden "theta_dot <= 5" --n 20
  mutual constraints simulate --world data/examples/world.toml --hidden "cell 4 0 psi 0.25" --hidden "action NW"
"""


def register(commands):
    """Add ``infer-continuous`` and ``simulate`` to the ``mutual constraints`` commands."""
    infer = common.add_command(commands, "infer-continuous", "constraints from continuous trajectories (extension)",
                               INFER_DESCRIPTION, INFER_EXAMPLE)
    infer.add_argument("trajectories", metavar="TRAJ.csv", help="the recorded trajectories (format: data/README.md)")
    infer.add_argument("--system", required=True, metavar="SYSTEM.toml", help="the system, its grid and task")
    infer.add_argument("--families", metavar="LIST", help="candidate families, comma-separated: bound, disk, box, cell "
                                                          "(default: [candidates] families, else bound)")
    infer.add_argument("--rounds", type=int, default=DEFAULT_ROUNDS, help=f"at most this many constraints "
                                                                          f"(default {DEFAULT_ROUNDS})")
    infer.add_argument("--model", choices=("points", "cells"), default="points",
                       help="points: the exact likelihood of the continuous demonstrations (default); "
                            "cells: chapters 2-3 on the discretized MDP")
    infer.add_argument("--min-gain", type=float, metavar="NATS",
                       help=f"accept a constraint only if it gains NATS per demonstration (points: exact gain, "
                            f"default {MIN_GAIN['points']}; cells: -log F, default {MIN_GAIN['cells']})")
    infer.add_argument("--temperature", metavar="fit|file|NUMBER", default="fit",
                       help="points: fit the reward's weights by maximum likelihood (default), or keep the file's "
                            "reward at its temperature (file) or at NUMBER")
    infer.add_argument("--top", type=int, default=DEFAULT_TOP, help=f"candidates printed per round (default {DEFAULT_TOP})")
    infer.add_argument("--cells", metavar="N[,N...]", help="cells per coordinate (overrides [state] cells)")
    infer.add_argument("--scheme", choices=("sample", "barycentric"), help="discretization (overrides the file)")
    infer.add_argument("--thresholds", choices=("lemma", "eq3.3"), default="lemma",
                       help="cells: chance thresholds by Lemma 3.2.1 exactly (default) or eq. 3.3")
    infer.add_argument("--truncate", action="store_true", help="cut demonstrations of different durations to the shortest")
    dask = infer.add_argument_group("where the discretization runs")
    dask.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786")
    dask.add_argument("--workers", type=int, help="workers of the embedded LocalCluster (default: one per core)")
    dask.add_argument("--inline", action="store_true", help="in this process, without Dask")
    common.add_output_options(infer)
    infer.set_defaults(handler=run_infer_continuous, prog=infer.prog)
    simulate = common.add_command(commands, "simulate",
                                  "write demonstrations of a system or a gridworld to try inference",
                                  SIMULATE_DESCRIPTION, SIMULATE_EXAMPLE)
    source = simulate.add_mutually_exclusive_group(required=True)
    source.add_argument("--system", metavar="SYSTEM.toml", help="a continuous system (writes trajectories.csv)")
    source.add_argument("--world", metavar="WORLD.toml", help="a gridworld (writes demonstrations.csv)")
    simulate.add_argument("--hidden", action="append", metavar="TEXT", help="a hidden constraint (repeatable; "
                                                                           "default: [simulate] hidden)")
    simulate.add_argument("--n", type=int, help="demonstrations (default: [simulate] n, else 20; gridworld 100)")
    simulate.add_argument("--seed", type=int, help="random seed (default: [simulate] seed, else 0)")
    simulate.add_argument("--demonstrator", choices=("soft", "mppi"), help="continuous demonstrator (default: the file's)")
    simulate.add_argument("--noise", type=float, help="suboptimal demonstrator: chance of a random safe action (soft) "
                                                      "or control noise as a share of the range (mppi)")
    simulate.add_argument("--no-controls", action="store_true", help="leave the control columns out (inference then "
                                                                     "infers the controls)")
    common.add_output_options(simulate)
    simulate.set_defaults(handler=run_simulate, prog=simulate.prog)


def _check_options(args):
    import math
    for name, value, low in (("--rounds", args.rounds, 1), ("--top", args.top, 1)):
        if value < low:
            raise common.InputError(f"{name} {value}: must be at least {low}")
    if args.min_gain is not None and (not math.isfinite(args.min_gain) or args.min_gain < 0):
        raise common.InputError(f"--min-gain {args.min_gain}: must be a finite number >= 0")
    if args.workers is not None and args.workers < 1:
        raise common.InputError(f"--workers {args.workers}: must be at least 1")
    if args.temperature not in ("fit", "file"):
        try:
            value = float(args.temperature)
        except ValueError:
            value = math.nan
        if not math.isfinite(value) or value <= 0:
            raise common.InputError(f"--temperature {args.temperature}: must be 'fit', 'file' or a positive number")
    if args.model == "cells" and args.temperature != "fit":
        raise common.InputError("--temperature: applies to --model points (the cells model uses the file's)")


def _with_overrides(args, problem, system_path):
    from ..constraints.continuous import with_cells
    if args.cells:
        try:
            cells = [int(c) for c in args.cells.split(",")]
        except ValueError:
            raise common.InputError(f"--cells {args.cells}: must be integers separated by commas") from None
        if len(cells) == 1:
            cells *= problem.grid.ndim
        if len(cells) != problem.grid.ndim or min(cells) < 2:
            raise common.InputError(f"--cells {args.cells}: needs one integer >= 2, or one per coordinate "
                                    f"({problem.grid.ndim} in {system_path})")
        problem = with_cells(problem, cells)
    return problem.replace(scheme=args.scheme) if args.scheme else problem


def run_infer_continuous(args):
    _check_options(args)
    traj_path, system_path = common.existing_file(args.trajectories), common.existing_file(args.system)
    continuous_sizes.check_inference(system_path, args)      # before the grid is built
    from ..constraints.continuous import check_recording, infer, load_system, read_recording
    with common.about(system_path):
        spec = load_system(system_path)
    problem = _with_overrides(args, spec.problem, system_path)
    families = [f.strip() for f in args.families.split(",")] if args.families else spec.candidates["families"]
    unknown = [f for f in families if f not in FAMILIES]
    if unknown:
        raise common.InputError(f"--families {args.families}: unknown family {unknown[0]!r}; choose from "
                                f"{', '.join(FAMILIES)}")
    if args.model == "points" and "cell" in families:
        raise common.InputError("--families: 'cell' candidates need --model cells (the points model proposes "
                                "bound, disk and box)")
    system = problem.system
    with common.about(traj_path), _dynamics_errors(system_path, system):
        recording = read_recording(traj_path, system.state_names, system.control_names)
        check_recording(problem, recording, args.truncate)
    with common.progress(args, total=100, desc="infer-continuous", unit="%",
                         bar_format="{l_bar}{bar}| {n:.0f}% [{elapsed}] {postfix}") as bar:
        def progress(fraction, detail):
            bar.update(max(0.0, 100.0 * fraction - bar.n))
            bar.set_postfix_str(detail[:60])

        with common.about(traj_path), _dynamics_errors(system_path, problem.system):
            gain = {} if args.min_gain is None else {"min_gain": args.min_gain}
            run = infer(problem, recording, families=families, rounds=args.rounds, truncate=args.truncate,
                        progress=progress, plane=spec.candidates["plane"], **gain, **_model_options(args, spec, problem))
        bar.update(100 - bar.n)
    report_inference(args, run, traj_path, system_path)


def _model_options(args, spec, problem):
    """The options of the chosen model: the points model's temperature and obstacle size, or the cells
    model's discretization, thresholds and candidate lattice."""
    if args.model == "points":
        temperature = {"fit": "fit", "file": problem.reward.temperature}.get(args.temperature)
        sizes = (spec.candidates["radii"] or []) + (spec.candidates["half_widths"] or [])
        return {"temperature": float(args.temperature) if temperature is None else temperature,
                "largest": max(sizes) if sizes else None}
    return {"model": "cells", "scheduler": "inline" if args.inline else (args.scheduler or "auto"),
            "workers": args.workers, "thresholds": args.thresholds, "every": spec.candidates["every"],
            "radii": spec.candidates["radii"], "half_widths": spec.candidates["half_widths"]}


@contextmanager
def _dynamics_errors(system_path, system):
    """A failure inside the dynamics (a user's ``module:function``) named by the system file, not the recordings."""
    try:
        yield
    except ValueError as err:
        if str(err).startswith(f"system {system.spec!r}"):
            raise common.InputError(f"{system_path}: key 'system': {err}") from None
        raise


def run_simulate(args):
    if args.n is not None and args.n < 1:
        raise common.InputError(f"--n {args.n}: must be at least 1")
    if args.seed is not None and args.seed < 0:
        raise common.InputError(f"--seed {args.seed}: must be >= 0")
    if args.noise is not None and not 0 <= args.noise:
        raise common.InputError(f"--noise {args.noise}: must be >= 0")
    (_simulate_world if args.world else _simulate_system)(args)


def _simulate_system(args):
    import numpy as np
    from ..constraints.continuous import (load_system, mppi_rollouts, parse_region, rollout, soft_demonstrator,
                                          starts_around, write_recording)
    path = common.existing_file(args.system)
    continuous_sizes.check_simulation(path, args)            # before the grid is built
    with common.about(path):
        spec = load_system(path)
    problem, sim = spec.problem, dict(spec.simulate)
    texts = args.hidden if args.hidden is not None else sim["hidden_text"]
    try:
        hidden = [parse_region(text, problem.grid.names, spec.candidates["plane"]) for text in texts]
    except ValueError as err:
        raise common.InputError(f"--hidden: {err}") from None
    from ..constraints.continuous import check_start
    with common.about(path):
        check_start(hidden, texts, sim["start"], sim["spread"], f"{path}: key 'simulate.start'")
    n, seed = args.n or sim["n"], sim["seed"] if args.seed is None else args.seed
    kind = args.demonstrator or sim["demonstrator"]
    noise = sim["noise"] if args.noise is None else args.noise
    starts = starts_around(sim["start"], sim["spread"], n, seed)
    with common.about(path), common.progress(args, total=1, desc=f"simulating ({kind})", unit="run") as bar:
        if kind == "soft":
            demonstrator = soft_demonstrator(problem, hidden, sim["fine_cells"], temperature=sim["temperature"])
            recording = rollout(demonstrator, starts, seed + 1, noise, sim["record_every"])
        else:
            recording = mppi_rollouts(problem.replace(reward=_tempered(problem.reward, sim["temperature"])), hidden,
                                      starts, seed + 1, sim["samples"], sim["plan_steps"], sim["sigma"], noise,
                                      sim["record_every"], sim["margin"])
        bar.update(1)
    if args.no_controls:
        from dataclasses import replace
        recording = replace(recording, controls=None)
    _check_inside(problem.grid, recording, path)
    with common.output_set(args) as files:
        write_recording(files.path("trajectories.csv"), recording, problem.system.state_names,
                        problem.system.control_names)
    out = files.final("trajectories.csv")
    states = np.concatenate(recording.states)
    ranges = {name: [float(states[:, i].min()), float(states[:, i].max())] for i, name in enumerate(problem.grid.names)}
    results = {"command": "constraints simulate", "system": str(path), "dynamics": problem.system.spec,
               "dynamics_file": problem.system.file, "demonstrator": kind, "hidden": list(texts),
               "n_demonstrations": n, "seed": seed, "noise": noise, "samples_per_demonstration": len(recording.times[0]),
               "period_seconds": float(recording.times[0][1] - recording.times[0][0]), "ranges": ranges,
               "controls_written": not args.no_controls, "outputs": {"trajectories": str(out)}}
    lines = [f"Simulated {n} demonstrations of {problem.system.spec!r}{code_note(problem.system.file)} ({kind} demonstrator "
             "on the continuous dynamics, "
             f"seed {seed}) under hidden constraints: {', '.join(texts) or 'none'}",
             *[f"  {name}: {lo:.4g} .. {hi:.4g}" for name, (lo, hi) in ranges.items()], f"wrote {out}"]
    common.report(args, "\n".join(lines), results)


def _check_inside(grid, recording, path):
    """Refuse, before anything is written, demonstrations that leave the system's box: ``infer-continuous``
    would refuse the file (the demonstrator plans on the box, the continuous dynamics can overshoot its edge)."""
    import numpy as np
    states = np.concatenate(recording.states)
    out = grid.outside(states)
    if out.any():
        i = int(np.argmax(out.any(axis=0)))
        values = states[out[:, i], i]
        far = float(values[np.argmax(np.abs(values - np.clip(values, grid.low[i], grid.high[i])))])
        raise common.InputError(
            f"{path}: {int(out.any(axis=1).sum())} of {len(states)} simulated samples leave the box of the system "
            f"({grid.names[i]!r} reaches {far:.4g}, outside [{grid.low[i]:g}, {grid.high[i]:g}]); infer-continuous "
            "would refuse them: widen [state] low/high in the system file (nothing was written)")


def _tempered(reward, temperature):
    from dataclasses import replace
    return replace(reward, temperature=float(temperature))


def _grid_hidden(texts, grid):
    """Chapter 3's ground truth from "cell COL ROW [psi P]" and "action NAME"."""
    from ..constraints import GRID_ACTIONS
    states, psi, actions = [], [], []
    for text in texts:
        words = text.split()
        try:
            if words[0] == "cell" and len(words) in (3, 5) and (len(words) == 3 or words[3] == "psi"):
                col, row = int(words[1]), int(words[2])
                if not (0 <= col < grid.width and 0 <= row < grid.height):
                    raise ValueError
                states.append(grid.state(col, row))
                psi.append(float(words[4]) if len(words) == 5 else 0.0)
                continue
            if words[0] == "action" and len(words) == 2 and words[1] in GRID_ACTIONS[:8]:
                actions.append(GRID_ACTIONS.index(words[1]))
                continue
        except (ValueError, IndexError):
            pass
        raise common.InputError(f"--hidden {text!r}: write 'cell COL ROW' (0 <= COL < {grid.width}, 0 <= ROW < "
                                f"{grid.height}), optionally followed by 'psi P', or 'action NAME' (E, NE, N, NW, W, SW, S, SE)")
    return states, psi, actions


def _simulate_world(args):
    from ..constraints import constraint_mask, sample_demonstrations, write_demonstrations
    from ..constraints import load_world
    path = common.existing_file(args.world)
    with common.about(path):
        grid = load_world(path)
    states, psi, actions = _grid_hidden(args.hidden or [], grid)
    if any(not 0 <= p <= 1 for p in psi):
        raise common.InputError("--hidden: psi must lie in [0, 1]")
    n, seed = args.n or 100, args.seed or 0
    budget.check(budget.demonstrations(n, grid.mdp.horizon))
    with common.about(path):
        mask = constraint_mask(grid.mdp, states, psi if psi else 0.0, actions)
        demos = sample_demonstrations(grid.mdp, n, mask, rng=seed)
    with common.output_set(args) as files:
        write_demonstrations(files.path("demonstrations.csv"), demos)
    out = files.final("demonstrations.csv")
    results = {"command": "constraints simulate", "world": str(path), "hidden": list(args.hidden or []),
               "n_demonstrations": n, "steps": demos.steps, "seed": seed, "outputs": {"demonstrations": str(out)}}
    common.report(args, f"Simulated {n} demonstrations of {demos.steps} steps in {path} (Boltzmann agent, seed {seed}) "
                        f"under: {', '.join(args.hidden or []) or 'no constraint'}\nwrote {out}", results)
