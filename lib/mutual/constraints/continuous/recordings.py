"""Recorded continuous trajectories: their CSV format and their alignment to the model's time step.

Trajectory CSV (``read_recording`` / ``write_recording``; data/README.md): a header ``demo, t``,
then one column per state coordinate (the system's names) and optionally one per control; one row
per recorded sample. ``demo`` is any text naming the demonstration (rows of one demonstration
together or not: they are ordered by ``t``), ``t`` is in seconds, sampled at a regular period; a
control may be empty where it was not recorded, and is ignored on each demonstration's last row.

:func:`align` keeps every k-th sample so that steps are ``dt`` apart (the period must divide ``dt``);
:mod:`.plausible` then checks what a user may have got wrong, and :mod:`.mapping` maps the states to cells
and the steps to actions.
"""

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ...atomic import atomic_path
from ...inputs import name_column, number_column, read_csv

_TOLERANCE = 1e-6   # relative: equal sampling periods, a period dividing dt


@dataclass(frozen=True, eq=False)
class Recording:
    """Continuous demonstrations: ``ids`` (text), and per demonstration ``times`` (L+1,), ``states``
    (L+1, n) and ``controls`` (L+1, m) (nan where not recorded) or None (no control columns).
    ``lines`` (per demonstration, the file line of each sample) and ``source`` name the origin."""

    ids: tuple
    times: tuple
    states: tuple
    controls: tuple = None
    lines: tuple = None
    source: str = "recording"
    notes: dict = field(default_factory=dict)

    def __len__(self):
        return len(self.ids)

    def __repr__(self):
        return (f"Recording({len(self)} demonstrations from {self.source}, "
                f"{'with' if self.controls is not None else 'without'} controls)")

    def line(self, d, k):
        return None if self.lines is None else int(self.lines[d][k])

    def where(self, d, k, column):
        """``'SOURCE, line L, column C'`` (or demo and sample) for error messages."""
        line = self.line(d, k)
        at = f"line {line}" if line is not None else f"demo {self.ids[d]!r}, sample {k}"
        return f"{self.source}, {at}, column {column!r}"


def recording_frame(recording, state_names, control_names=None):
    """The recording as a DataFrame in the CSV format (controls empty where not recorded)."""
    frames = []
    for d, ident in enumerate(recording.ids):
        frame = pd.DataFrame({"demo": ident, "t": recording.times[d]})
        for i, name in enumerate(state_names):
            frame[name] = recording.states[d][:, i]
        if recording.controls is not None and control_names:
            for j, name in enumerate(control_names):
                frame[name] = recording.controls[d][:, j]
        frames.append(frame)
    return pd.concat(frames, ignore_index=True)


def write_recording(path, recording, state_names, control_names=None):
    """Write a recording atomically as trajectory CSV (module docstring)."""
    frame = recording_frame(recording, state_names, control_names)
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False, float_format="%.10g")
    return path


def read_recording(path, state_names, control_names=()):
    """Read trajectory CSV (module docstring; :func:`mutual.inputs.read_csv`); every problem raises a
    ValueError naming the file, the line (1 = the header) and the column. Demonstration names that differ
    only by surrounding spaces are refused as ambiguous."""
    frame = read_csv(path, ("demo", "t", *state_names))
    ids = name_column(frame, "demo").to_numpy()
    t = number_column(frame, "t")
    states = np.stack([number_column(frame, c) for c in state_names], axis=1)
    present = [c for c in control_names if c in frame.columns]
    if present and len(present) != len(control_names):
        raise ValueError(f"{path}, line 1: has control column {present[0]!r} but not "
                         f"{[c for c in control_names if c not in present][0]!r}; give all controls or none")
    controls = np.stack([number_column(frame, c, True) for c in control_names], axis=1) if present else None
    line = np.asarray(frame.attrs["lines"])
    out = {"ids": [], "times": [], "states": [], "controls": [], "lines": []}
    codes, names = pd.factorize(ids)                       # in order of first appearance
    order = np.lexsort((t, codes))                         # by demonstration, then by t (ties as in the file)
    for ident, rows in zip(names, np.split(order, np.flatnonzero(np.diff(codes[order])) + 1)):
        if rows.size < 2:
            raise ValueError(f"{path}, line {line[rows[0]]}, column 'demo': demonstration {ident!r} has one row; "
                             "a demonstration needs at least two samples")
        for key, value in (("ids", ident), ("times", t[rows]), ("states", states[rows]), ("lines", line[rows]),
                           ("controls", None if controls is None else controls[rows])):
            out[key].append(value)
    return Recording(tuple(out["ids"]), tuple(out["times"]), tuple(out["states"]),
                     None if controls is None else tuple(out["controls"]), tuple(out["lines"]), str(path))


def _stride(recording, d, dt):
    """Samples per step of ``dt`` in demonstration d, checking the sampling is regular."""
    t = recording.times[d]
    steps = np.diff(t)
    period = steps[0]
    repeated = np.flatnonzero(steps <= 0)
    if repeated.size:
        k = int(repeated[0]) + 1
        raise ValueError(f"{recording.where(d, k, 't')}: time {t[k]:g} repeats the previous sample's time")
    off = np.flatnonzero(np.abs(steps - period) > _TOLERANCE * max(period, 1e-12) + 1e-12)
    if off.size:
        k = int(off[0]) + 1
        what = "a gap in time" if steps[k - 1] > period else "a sample closer than the period"
        raise ValueError(f"{recording.where(d, k, 't')}: time jumps from {t[k - 1]:g} to {t[k]:g} s but demonstration "
                         f"{recording.ids[d]!r} is sampled every {period:g} s ({what}); resample it regularly")
    ratio = dt / period
    if ratio < 1 - _TOLERANCE or abs(ratio - round(ratio)) > _TOLERANCE * ratio:
        raise ValueError(f"{recording.where(d, 1, 't')}: demonstration {recording.ids[d]!r} is sampled every "
                         f"{period:g} s, which does not divide the model's time step dt = {dt:g} s")
    return int(round(ratio))


def align(recording, dt, truncate=False):
    """``(states (N, L+1, n), controls (N, L, m) or None, sample index (N, L+1))``: every k-th sample so
    that steps are ``dt`` apart, controls averaged over each step. Demonstrations must span the
    same number of steps (``truncate``: cut them to the shortest)."""
    picks = []
    for d in range(len(recording)):
        k = _stride(recording, d, dt)
        picks.append((k, np.arange(0, recording.times[d].size, k)))
    lengths = [p.size for _, p in picks]
    if min(lengths) < 2:
        d = int(np.argmin(lengths))
        raise ValueError(f"{recording.where(d, 0, 't')}: demonstration {recording.ids[d]!r} is shorter than one "
                         f"step of dt = {dt:g} s")
    if len(set(lengths)) > 1 and not truncate:
        d = int(np.argmax(np.array(lengths) != lengths[0]))
        raise ValueError(f"{recording.where(d, 0, 't')}: demonstration {recording.ids[d]!r} spans {lengths[d] - 1} "
                         f"steps of dt = {dt:g} s, demonstration {recording.ids[0]!r} {lengths[0] - 1}; every "
                         "demonstration must span the same time (trim them, or truncate to the shortest)")
    L = min(lengths) - 1
    states = np.stack([recording.states[d][p[: L + 1]] for d, (_, p) in enumerate(picks)])
    index = np.stack([p[: L + 1] for _, p in picks])
    controls = None
    if recording.controls is not None:
        controls = np.stack([_step_controls(recording.controls[d], p, k, L) for d, (k, p) in enumerate(picks)])
    return states, controls, index


def _step_controls(C, picks, k, L):
    """(L, m): the mean of the fully recorded controls within each step, nan where there is none."""
    out = np.full((L, C.shape[1]), np.nan)
    for i in range(L):
        window = C[picks[i]: picks[i] + k]
        window = window[np.isfinite(window).all(axis=1)]
        if len(window):
            out[i] = window.mean(axis=0)
    return out
