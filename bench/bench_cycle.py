"""Chapter 8's Explore views: how long one redraw takes (target: about a second on 2 cores, issue 12).

There is no baseline: these are interactive views, timed as a reader meets them, the first call at
each setting (the inference and the value-function library are cached across calls, as in a session).
"""

import time

import matplotlib

matplotlib.use("Agg")

from mutual.cycle import explore  # noqa: E402


def _time(fn, **kwargs):
    start = time.perf_counter()
    fn(**kwargs)
    return time.perf_counter() - start


def run(quick=False):
    warm = _time(explore.continuous_view, n_interventions=10)          # builds the cached library once
    rows = [{"benchmark": "cycle explore", "case": "continuous_view, first call (builds the closed-form library of 12 "
             "value functions, 101 x 101 x 64)", "seconds": warm, "target": "once per session"}]
    cases = [("discrete_view", explore.discrete_view, {"n_demos": n, "alpha": 1.0, "seed": 1})
             for n in ((20,) if quick else (20, 50, 200))]
    cases += [("continuous_view", explore.continuous_view, {"n_interventions": n, "k": 2.0, "seed": 1})
              for n in ((20,) if quick else (20, 40, 100))]
    for name, fn, kwargs in cases:
        seconds = _time(fn, **kwargs)
        rows.append({"benchmark": "cycle explore", "case": f"{name}({', '.join(f'{k}={v}' for k, v in kwargs.items())})",
                     "seconds": seconds, "baseline": None, "baseline_seconds": None,
                     "compile_seconds": None, "agree": None,
                     "target": "<= 2 s per redraw", "met": seconds <= 2.0})
    return rows
