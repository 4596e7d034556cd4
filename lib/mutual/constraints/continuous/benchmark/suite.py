"""Running the benchmark: every case of a split through every method, scored the same way.

:func:`run_benchmark` is the one call (``split="development"`` to tune on, ``"held-out"`` only at the
end); it returns one row per case with, for each method (``inference``: the library's, through the
Python API or for ``VIA_CLI`` cases the command line; ``naive``: the tightest constraint the data
allow; ``kkt``: the KKT peer), the numbers of :func:`.scoring.score`. :func:`summary_table` is the
short table (system, demonstrator, truth, errors, kind, false positives); :func:`wins` counts where
each method wins.
"""

import math
import time

import numpy as np
import pandas as pd

from ....parallel import INLINE, map_tasks
from . import methods
from .cases import case_csv, case_recording, cases
from .scoring import Answer, describe, score

METHODS = ("inference", "naive", "kkt")
#: the quick version (make test, make bench QUICK=1): one approached bound, one unconstrained case
QUICK = ("pendulum-A-filter-narrow", "double_integrator-U-lagged-wide")


def _answer(method, case, spec, recording):
    if method == "inference":
        if case.via_cli:
            return methods.cli_answer(case.setup.text, case_csv(case), spec.problem.grid.names)
        return methods.inference_answer(spec, recording)
    if method == "naive":
        return methods.naive_answer(spec, recording, case.regions())
    if method == "kkt":
        return methods.kkt_answer(spec, recording)
    raise ValueError(f"methods: unknown method {method!r}; known: {', '.join(METHODS)}")


def _approach(case):
    return {"A": "approached", "B": "approached", "F": "far", "U": "none"}[case.truth]


def case_row(case, methods_=METHODS):
    """The scored row of one case (module docstring)."""
    spec, recording, truth = case.setup.system_file(), case_recording(case), case.regions()
    names = spec.problem.grid.names
    row = {"case": case.id, "split": case.split, "system": case.system, "demonstrator": f"{case.kind} ({case.starts})",
           "truth": case.truth_text, "truth kind": _approach(case)}
    for method in methods_:
        try:
            answer = _answer(method, case, spec, recording)
        except Exception as err:  # noqa: BLE001 (one method's failure is a result of the benchmark, not its end)
            answer = Answer((), None, math.nan, f"FAILED: {type(err).__name__}: {err}")
        numbers = score(answer, truth)
        if method == "naive" and truth and truth[0].kind == "bound":
            numbers["error"] = methods.naive_oracle_error(spec, recording, truth)
        numbers["first"] = describe(answer.regions[0], names) if answer.regions else "none"
        numbers["chosen"] = "; ".join(describe(r, names) for r in answer.regions) or "none"
        row |= {f"{method}: {k}": v for k, v in numbers.items()}
        row[f"{method}: seconds"] = answer.seconds
        row[f"{method}: note"] = answer.note
    return row


def _timed_row(case, methods_):
    start = time.perf_counter()
    return case_row(case, methods_), time.perf_counter() - start


def run_benchmark(split="development", methods=METHODS, systems=None, quick=False, progress=None, scheduler=None,
                  workers=None):
    """One row per case of ``split`` ("development", "held-out" or "all"; ``systems``: some of them;
    ``quick``: only the cases of QUICK, in this process) for each of ``methods``; ``progress(case, seconds)``
    is called as each case finishes. The cases are independent tasks (:func:`mutual.parallel.map_tasks`): an embedded
    cluster of ``workers`` processes (default one per core; a script that calls it needs an
    ``if __name__ == "__main__":`` guard, as for any spawned process), a ``scheduler`` of your own, or "inline";
    the rows are the same, in case order, wherever they ran. The methods' seconds are measured in the worker
    beside the others: with several workers on a machine, they are not one process's times."""
    chosen = [c for c in cases(split, systems) if not quick or c.id in QUICK]
    done = None if progress is None else (lambda i, result: progress(chosen[i], result[1]))
    alone = scheduler is None and (quick or len(chosen) < 2)   # no cluster: starting one costs more than it saves
    results, _ = map_tasks(_timed_row, chosen, shared=(tuple(methods),), scheduler=INLINE if alone else scheduler,
                           workers=workers, on_result=done)
    return pd.DataFrame([row for row, _ in results])


def _number(value, digits=3):
    return "-" if value is None or (isinstance(value, float) and not math.isfinite(value)) else \
        (f"{value:.{digits}f}" if isinstance(value, float) else str(value))


def _error_text(row, method):
    error, size = row.get(f"{method}: error"), row.get(f"{method}: size error")
    if error is None:
        return "-"
    if isinstance(size, float) and math.isfinite(size):
        return f"{_number(error, 2)} / {_number(size, 2)}"
    if not math.isfinite(error):
        return "not found" if row["truth kind"] != "none" else "-"
    return _number(error)


def summary_table(frame, methods_=METHODS):
    """The benchmark's short table: per case the system, demonstrator, truth, each method's error
    (bounds: |value - true value|; obstacles: centre / size error in m), whether its first constraint
    was of the right kind, its false positives, and for the inference the accepted constraints that
    lowered the exact likelihood."""
    out = []
    for _, row in frame.iterrows():
        line = {"case": row["case"], "split": row["split"], "system": row["system"],
                "demonstrator": row["demonstrator"], "truth": f"{row['truth']} ({row['truth kind']})"}
        for m in methods_:
            if f"{m}: error" not in row:
                continue
            line[f"{m} error"] = _error_text(row, m)
            line[f"{m} kind right"] = "yes" if row[f"{m}: kind right"] else "no"
            line[f"{m} false positives"] = int(row[f"{m}: false positives"])
        if "inference: lowered likelihood" in row:
            line["inference: lowered the likelihood"] = _number(row["inference: lowered likelihood"])
            line["inference: chosen"] = row["inference: chosen"]
        out.append(line)
    return pd.DataFrame(out)


def wins(frame, a="inference", b="naive", tolerance=0.05):
    """Per system: cases where ``a``'s error is within ``tolerance`` of ``b``'s or smaller (cases both
    found), where it is not, and where only one of them found the truth's kind."""
    rows = []
    for system, part in frame.groupby("system", sort=False):
        ea, eb = part[f"{a}: error"].astype(float), part[f"{b}: error"].astype(float)
        both = np.isfinite(ea) & np.isfinite(eb)
        rows.append({"system": system, f"{a} within {tolerance} of {b} or better": int(np.sum(both & (ea <= eb + tolerance))),
                     f"{a} worse by more than {tolerance}": int(np.sum(both & (ea > eb + tolerance))),
                     f"only {a} found it": int(np.sum(np.isfinite(ea) & ~np.isfinite(eb))),
                     f"only {b} found it": int(np.sum(~np.isfinite(ea) & np.isfinite(eb)))})
    return pd.DataFrame(rows)
