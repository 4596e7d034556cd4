"""Notebook 09's measurements: how the discretization and the inference behave as settings change.

* :func:`scheme_agreement` -- the two discretizations against the true successor and each other;
* :func:`resolution_sweep` -- boundary error against grid resolution (both schemes);
* :func:`demos_sweep` -- boundary error against the number of demonstrations (several draws);
* :func:`robustness` -- one row per hyperparameter variant (resolution, time step, control set,
  temperature, scheme, samples, thresholds);
* :func:`seeded_recordings`, :func:`seeded_mppi`, :func:`inside_box`, :func:`seeded_runs`, :func:`claim_verdict`
  -- a claim checked over seeds and settings against the truth and the naive bound (the tightest bound the
  recordings allow), with a verdict by CLAIMS.md's rules;
* :func:`measured` -- a run's wall time and peak memory in a fresh process (no timings reach the
  notebook's saved results: they vary from run to run).
"""

import math
import multiprocessing
import resource
import time
from dataclasses import replace

import numpy as np
import pandas as pd

from .demonstrators import mppi_rollouts, rollout, starts_around
from .discretization import discretize
from .grid import Grid
from .inference import boundary_errors, infer
from .regions import boundary_distance


ROUNDING = 1e-12   # distances below this are float64 rounding (their digits vary by machine): reported as 0


def with_cells(problem, cells):
    """``problem`` on a uniform grid of ``cells`` per coordinate (an int for all) over the same box."""
    g = problem.grid
    cells = [cells] * g.ndim if np.isscalar(cells) else list(cells)
    return problem.replace(grid=Grid.uniform(g.low, g.high, cells, g.periodic, g.names, g.units))


def with_dt(problem, dt):
    """``problem`` with time step ``dt`` and the horizon that keeps its duration T dt."""
    return problem.replace(dt=float(dt), horizon=max(1, int(round(problem.horizon * problem.dt / dt))))


def with_levels(problem, n):
    """``problem`` with ``n`` evenly spaced levels of a one-dimensional control between its extremes."""
    lo, hi = problem.controls.min(), problem.controls.max()
    return problem.replace(controls=np.linspace(lo, hi, int(n))[:, None])


def scheme_agreement(problem, resolutions):
    """Per resolution: for interior cells, the mean distance from each scheme's expected successor
    centre to the true successor of the cell centre, and the largest gap between the two schemes'
    expected successors (distances in units of the box, each coordinate divided by its extent; below
    ``ROUNDING`` reported as 0: the barycentric scheme's is exact up to rounding)."""
    rows = []
    for cells in resolutions:
        p = with_cells(problem, cells)
        g, A = p.grid, p.n_actions
        centres = g.centers()
        scale = g.high - g.low
        truth = p.step(np.repeat(centres, A, axis=0), np.tile(p.controls, (g.n_cells, 1)))
        inside = (truth > g.low + 0.1 * scale) & (truth < g.high - 0.1 * scale)
        inner = np.all(inside | np.asarray(g.periodic)[None], axis=1)       # away from the clipped edges
        means = {}
        for scheme in ("sample", "barycentric"):
            S = discretize(p.replace(scheme=scheme), scheduler="inline")
            means[scheme] = _expected_successor(S, g, truth)
        row = {"cells": g.n_cells, "cells per coordinate": " x ".join(map(str, g.shape)),
               "largest cell width": float(max((np.diff(e) / (e[-1] - e[0])).max() for e in g.edges))}
        for scheme, mean in means.items():
            gap = float(np.mean(np.linalg.norm((mean - truth)[inner] / scale, axis=1)))
            row[f"{scheme}: mean |E x' - x'|"] = gap if gap > ROUNDING else 0.0     # exact up to rounding: 0
        row["max |sample - barycentric|"] = float(np.max(np.linalg.norm(
            (means["sample"] - means["barycentric"])[inner] / scale, axis=1)))
        rows.append(row)
    return pd.DataFrame(rows)


def _expected_successor(S, grid, reference):
    """E_{x' ~ S(x, a, .)}[centre of x'] (X*A, d), periodic coordinates unwrapped around ``reference``."""
    coo = S.tocoo()
    centres = grid.centers()[coo.col]
    for i in np.flatnonzero(grid.periodic):
        period = grid.high[i] - grid.low[i]
        d = centres[:, i] - reference[coo.row, i]
        centres[:, i] = reference[coo.row, i] + np.mod(d + period / 2, period) - period / 2
    out = np.zeros((S.shape[0], grid.ndim))
    for i in range(grid.ndim):
        out[:, i] = np.bincount(coo.row, weights=coo.data * centres[:, i], minlength=S.shape[0])
    return out


def summary(run, truth):
    """One row about an inference (either model) against the ``truth`` regions: the chosen constraints, F
    of the first, whether the first is of the truth's kind and on its coordinates, the boundary error(s)
    (:func:`.inference.boundary_errors`); the points model adds the first one's likelihood interval, the
    cells model the thresholds Lemma 3.2.1 raised and the steps S gave probability 0."""
    errors = boundary_errors(run, truth)
    regions = run.chosen_regions()
    first = regions[0] if regions else None
    first_error = boundary_distance(first, truth[0]) if first is not None and truth else math.nan
    row = {"chosen": "; ".join(run.labels()) or "none",
           "first is the true kind": bool(np.isfinite(first_error)),
           **{("error" if len(truth) == 1 else f"error {n}"): e for n, e in enumerate(errors)}}
    if hasattr(run, "candidates"):
        return {**row, "F of the first": float(run.result.F[0]) if regions else math.nan,
                "thresholds raised": run.candidates.raised, "zero-probability steps": run.mapped.added}
    interval = run.accepted[0]["interval"] if regions else (math.nan, math.nan)
    return {**row, "F of the first": math.exp(-run.accepted[0]["gain"] / run.data.n) if regions else math.nan,
            "interval of the first": f"[{interval[0]:.4g}, {interval[1]:.4g}]" if regions else "none"}


def resolution_sweep(problem, recording, resolutions, truth, schemes=("sample", "barycentric"), **options):
    """Boundary error of the inferred constraint against the ``truth`` regions, per scheme and
    resolution (``options`` go to :func:`.inference.infer`)."""
    rows = []
    for scheme in schemes:
        for cells in resolutions:
            p = with_cells(problem, cells).replace(scheme=scheme)
            run = infer(p, recording, **options)
            rows.append({"scheme": scheme, "cells": p.grid.n_cells, "cells per coordinate": " x ".join(map(str, p.grid.shape)),
                         **summary(run, truth)})
    return pd.DataFrame(rows)


def first_demonstrations(recording, n):
    """The recording's first ``n`` demonstrations."""
    return replace(recording, **{k: getattr(recording, k)[:n] for k in ("ids", "times", "states")},
                   controls=None if recording.controls is None else recording.controls[:n],
                   lines=None if recording.lines is None else recording.lines[:n])


def tempered(reward, factor):
    """``reward`` with its temperature multiplied by ``factor``."""
    return replace(reward, temperature=reward.temperature * float(factor))


def demos_sweep(problem, recordings, counts, truth, **options):
    """Boundary error against the number of demonstrations: ``recordings`` is a list of recordings
    (independent draws); for each and each n in ``counts``, inference on its first n demonstrations."""
    rows = []
    for draw, recording in enumerate(recordings):
        for n in counts:
            run = infer(problem, first_demonstrations(recording, n), **options)
            rows.append({"draw": draw, "demonstrations": n, **summary(run, truth)})
    return pd.DataFrame(rows)


def robustness(problem, recording, variants, truth, **options):
    """One row per variant: ``variants`` maps a label to a function of the problem returning the
    varied problem (e.g. ``lambda p: with_dt(p, 0.05)``) or to a dict of extra ``infer`` options."""
    rows = []
    for label, change in variants.items():
        p, extra = (change(problem), {}) if callable(change) else (problem, dict(change))
        run = infer(p, recording, **(options | extra))
        rows.append({"setting": label, "cells": p.grid.n_cells, "controls": p.n_actions, "dt": p.dt,
                     "temperature": p.reward.temperature, "scheme": p.scheme, **summary(run, truth)})
    return pd.DataFrame(rows)


def naive_bound(recording, truth):
    """The one-line baseline: the recordings' extreme value on a true bound's coordinate and side."""
    values = np.concatenate([np.asarray(s, dtype=float)[:, truth.dim] for s in recording.states])
    return float(values.max() if truth.side == "upper" else values.min())


def judged(run, recording, truth, tolerance=0.05, obstacle_tolerance=0.1):
    """One run against one true region: the first accepted constraint, whether it is the truth's kind on
    its coordinates (and side), its error in the truth's units; for a bound also the naive bound's error and
    whether ours is within ``tolerance`` of it; for an obstacle whether centre and size are each within
    ``obstacle_tolerance``; ``ok``: all of these."""
    regions = run.chosen_regions()
    first = regions[0] if regions else None
    error = boundary_distance(first, truth) if first is not None else math.nan
    row = {"first": first.describe(run.problem.grid) if first is not None else "none", "right kind": bool(np.isfinite(error)),
           "error": error}
    if truth.kind == "bound":
        naive = abs(naive_bound(recording, truth) - truth.value)
        row.update({"naive error": naive, "ok": bool(np.isfinite(error) and error <= naive + tolerance)})
    else:
        centre = float(np.hypot(*np.subtract(first.center, truth.center))) if row["right kind"] else math.nan
        size = abs(first.radius - truth.radius) if row["right kind"] else math.nan
        row.update({"centre error": centre, "size error": size,
                    "ok": bool(row["right kind"] and centre <= obstacle_tolerance and size <= obstacle_tolerance)})
    if regions and hasattr(run, "accepted"):
        low, high = run.accepted[0]["interval"]
        value = truth.value if truth.kind == "bound" else truth.radius
        row["interval covers truth"] = bool(row["right kind"] and low <= value <= high)
    return row


def seeded_recordings(demonstrator, noise=0.0, *, start, spread, n, record_every=2):
    """``make_recording`` for :func:`seeded_runs`: seed ``s`` -> ``n`` demonstrations of ``demonstrator``
    (:func:`~.demonstrators.rollout` with action ``noise``) from starts drawn around ``start`` +- ``spread``
    with seed ``s``, the rollout seeded ``s + 1``."""
    return lambda s: rollout(demonstrator, starts_around(start, spread, n, s), s + 1, noise=noise,
                             record_every=record_every)


def inside_box(recording, grid):
    """``recording`` without the demonstrations that leave ``grid``'s box (what :func:`infer` asks a user to do
    with such samples); how many were dropped is in ``notes["left the box"]``."""
    keep = [d for d, states in enumerate(recording.states) if not grid.outside(states).any()]

    def pick(parts):
        return None if parts is None else tuple(parts[d] for d in keep)
    return replace(recording, ids=pick(recording.ids), times=pick(recording.times), states=pick(recording.states),
                   controls=pick(recording.controls), lines=pick(recording.lines),
                   notes={**recording.notes, "left the box": len(recording) - len(keep)})


def seeded_mppi(problem, hidden, *, start, spread, n, **options):
    """``make_recording`` for :func:`seeded_runs`: seed ``s`` -> ``n`` MPPI demonstrations
    (:func:`~.demonstrators.mppi_rollouts` with ``options``) from starts drawn around ``start`` +- ``spread``
    with seed ``s``, the planner seeded ``s + 1``; a demonstration the planner lets leave the problem's box
    (a cart-pole that tips past the box's angle) is dropped (:func:`inside_box`)."""
    return lambda s: inside_box(mppi_rollouts(problem, hidden, starts_around(start, spread, n, s), s + 1, **options),
                                problem.grid)


def seeded_runs(problem, make_recording, seeds, truth, setting="", **options):
    """:func:`judged` rows of ``infer`` on ``make_recording(seed)`` for each seed (``options`` to infer)."""
    rows = []
    for seed in seeds:
        recording = make_recording(seed)
        rows.append({"setting": setting, "seed": seed, "demonstrations": len(recording),
                     **judged(infer(problem, recording, **options), recording, truth)})
    return pd.DataFrame(rows)


def claim_verdict(table, by="setting", holds=0.9):
    """A verdict from per-seed outcomes (column ``ok``) per setting (CLAIMS.md rule 2): "reproduced" when
    every setting succeeds in at least ``holds`` of its seeds, "differs" when every setting fails in at
    least that share, "undetermined" otherwise; with the success share per setting as text."""
    share = table.groupby(by, sort=False)["ok"].mean()
    shares = "; ".join(f"{k}: {v:.0%}" for k, v in share.items())
    if (share >= holds).all():
        return "reproduced", shares
    if (share <= 1 - holds).all():
        return "differs", shares
    return "undetermined", shares


def _child(fn, args, kwargs, queue):
    start = time.perf_counter()
    result = fn(*args, **kwargs)
    queue.put((result, time.perf_counter() - start, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024))


def measured(fn, *args, fresh=True, **kwargs):
    """``(result, seconds, peak MiB)`` of ``fn(*args, **kwargs)`` run in a fresh process (spawned:
    the peak resident memory is that run's, plus the imported libraries). ``fn`` and its arguments
    and result must pickle; ``fn`` must be importable (a module-level function). ``fresh=False`` (a
    quick run): in this process, without the start of a new one, and the peak memory is nan."""
    if not fresh:
        start = time.perf_counter()
        result = fn(*args, **kwargs)
        return result, time.perf_counter() - start, math.nan
    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    child = context.Process(target=_child, args=(fn, args, kwargs, queue))
    child.start()
    try:
        result = queue.get(timeout=3600)
    finally:
        child.join()
    return result


def timed_inference(problem, recording, truth=(), **options):
    """A picklable summary of :func:`.inference.infer` for :func:`measured`: the cells, the stages'
    seconds, the chosen constraints and their ``regions``, the boundary error against each region of
    ``truth``."""
    import mutual  # noqa: F401  (the XLA setting, as in the parent)
    run = infer(problem, recording, **options)
    scored = len(run.candidates) if hasattr(run, "candidates") else sum(len(t) for t in run.rounds)
    return {"cells": problem.grid.n_cells, **{f"{k} s": v for k, v in run.seconds.items()},
            "candidates": scored, **summary(run, list(truth)), "regions": run.chosen_regions()}


def idle_memory(fresh=True):
    """Peak resident memory (MiB) of a fresh process that only imports the libraries and compiles nothing
    (nan without ``fresh``: a quick run starts no process)."""
    return measured(_nothing, fresh=fresh)[2]


def _nothing():
    import jax  # noqa: F401
    import mutual.constraints.continuous  # noqa: F401
    return None


def reportable(value):
    """A boundary error for the report: the number, or "not found" where no constraint of the true
    region's kind was chosen (nan)."""
    value = float(value)
    return value if math.isfinite(value) else "not found"
