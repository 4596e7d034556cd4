"""Timing shared by the peers benches: the median wall time of many calls after a warm-up, the
callables interleaved so that a change in the machine's load falls on both sides alike."""

import time

import numpy as np


def timed(fn):
    """``(seconds, fn())`` of one call."""
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


def interleaved(fns, runs, warmup=3):
    """Per callable: the median, min and max wall time (seconds) of ``runs`` calls, made in rounds
    that call each once, after ``warmup`` rounds that are not timed; and each callable's last output."""
    outs = [None] * len(fns)
    for _ in range(warmup):
        outs = [fn() for fn in fns]
    times = np.empty((runs, len(fns)))
    for r in range(runs):
        for i, fn in enumerate(fns):
            times[r, i], outs[i] = timed(fn)
    return [dict(median=float(np.median(t)), min=float(t.min()), max=float(t.max()), runs=runs)
            for t in times.T], outs
