"""The methods the benchmark scores, each behind one small function that returns an :class:`Answer`.

* :func:`inference_answer` -- the library's continuous constraint inference
  (:func:`mutual.constraints.continuous.infer`) at its defaults, with the candidate families of the
  user's system file: THE adapter; a change of the method's public API is absorbed here only;
* :func:`cli_answer` -- the same through ``mutual constraints infer-continuous --json``, as a user
  would run it on the case's files;
* :func:`naive_answer` -- the tightest constraint the data allow (:mod:`.naive`);
* :func:`kkt_answer` -- the KKT-based peer of Chou, Ozay and Berenson (:mod:`.kkt`).
"""

import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ..regions import Bound, Box, Disk
from . import naive
from .scoring import Answer


def inference_answer(spec, recording):
    """The library's inference on ``recording`` with the system file ``spec`` (its problem and
    [candidates]) at every default: the accepted regions, their exact gains, how it stopped."""
    from .. import infer
    c = spec.candidates
    sizes = (c["radii"] or []) + (c["half_widths"] or [])
    start = time.perf_counter()
    run = infer(spec.problem, recording, families=c["families"], plane=c["plane"], largest=max(sizes) if sizes else None)
    chosen = run.chosen()
    gains = tuple(float(g) for g in chosen["gain_refit"]) if len(chosen) else ()
    return Answer(tuple(run.chosen_regions()), gains, time.perf_counter() - start, f"stopped by {run.stop}")


def cli_answer(spec_text, csv_path, names):
    """``mutual constraints infer-continuous CSV --system SYSTEM.toml --json`` on the case's files
    (the system file written from ``spec_text``); the accepted regions rebuilt from its JSON
    (``names``: the state coordinates)."""
    with tempfile.TemporaryDirectory(prefix="benchmark-cli-") as folder:
        system = Path(folder) / "system.toml"
        system.write_text(spec_text)
        command = [sys.executable, "-m", "mutual.cli", "constraints", "infer-continuous", str(csv_path),
                   "--system", str(system), "--json", "--inline", "--out", str(Path(folder) / "out")]
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, env=os.environ | {"TQDM_DISABLE": "1"})
        seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"mutual constraints infer-continuous failed ({done.returncode}): {done.stderr.strip()}")
    out = json.loads(done.stdout)
    regions = tuple(region_of_record(r, names) for r in out["chosen"])
    return Answer(regions, tuple(float(r["gain_refit"]) for r in out["chosen"]), seconds,
                  f"via the command line; stopped: {out['stopped']}")


def region_of_record(record, names):
    """A region from one row of the command line's chosen constraints (its columns: kind, name, side,
    value or centre, radius and half-widths)."""
    kind = record["kind"]
    if kind == "bound":
        return Bound(list(names).index(record["name"]), record["side"], float(record["value"]))
    dims = tuple(list(names).index(n) for n in record["name"].split(","))
    centre = (float(record["center_0"]), float(record["center_1"]))
    if kind == "disk":
        return Disk(dims, centre, float(record["radius"]))
    if kind == "box":
        half = (float(record["half_width_0"]), float(record["half_width_1"]))
        return Box(dims, (centre[0] - half[0], centre[1] - half[1]), (centre[0] + half[0], centre[1] + half[1]))
    return None


def _states(spec, recording):
    """Every recorded state (wrapped), all demonstrations together."""
    return spec.problem.grid.wrap(np.concatenate(recording.states))


def naive_answer(spec, recording, truth):
    """The naive user's answer (:mod:`.naive`): on a system with obstacle candidates, the largest
    empty disk (or box, when the truth is a box) in the plane; else :func:`.naive.naive_pick`."""
    start = time.perf_counter()
    states, grid = _states(spec, recording), spec.problem.grid
    if any(f in spec.candidates["families"] for f in ("disk", "box")):
        plane = spec.candidates["plane"]
        points = states[:, list(plane)]
        boxed = bool(truth) and isinstance(truth[0], Box)
        region = naive.largest_empty_box(points, plane) if boxed else naive.largest_empty_disk(points, plane)
    else:
        region = naive.naive_pick(states, grid.low, grid.high, grid.periodic)
    return Answer((region,), None, time.perf_counter() - start, "always answers")


def naive_oracle_error(spec, recording, truth):
    """The tightest bound's error when told the true coordinate and side (nan for obstacles and
    unconstrained cases: the oracle needs a true bound)."""
    if not truth or not isinstance(truth[0], Bound):
        return math.nan
    bound = naive.tightest_bound(_states(spec, recording), truth[0].dim, truth[0].side)
    return abs(bound.value - truth[0].value)


def kkt_answer(spec, recording):
    """The KKT peer (:func:`.kkt_search.kkt_inference`) on the same files, with the same candidate families."""
    from .kkt_search import kkt_inference
    start = time.perf_counter()
    result = kkt_inference(spec, recording)
    return Answer(tuple(result.regions), None, time.perf_counter() - start, result.note)
