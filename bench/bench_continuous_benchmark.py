"""The continuous-constraint benchmark (mutual.constraints.continuous.benchmark): accuracy and time of
the library's inference, the naive tightest bound and the KKT peer on recordings none of them made.

Rows: one per system and split (development, then held-out), each the sum of the inference's seconds
over its cases beside the naive baseline's and the KKT peer's, and in ``agree`` how the errors
compare (the issue's target: every bound within 0.05 of the naive bound's error or better, every
obstacle within 0.1 m, the right kind first, no false positive, no accepted constraint that lowers
the exact likelihood). The per-case table goes to build/bench/continuous-benchmark.md and .csv.
The cases run in parallel, one worker process per core (``run_benchmark``'s embedded Dask cluster): the
seconds per system are summed over cases that shared the machine, the suite's wall time is in each row.
Quick: the two cases of ``suite.QUICK`` (the ones ``make test`` runs). The recordings are cached
(``$MUTUAL_CACHE_DIR/continuous-benchmark``); a cold cache adds their generation (about a minute).
"""

import os
import time

import numpy as np


def _agree(part):
    def summary(method):
        err = part[f"{method}: error"].astype(float)
        found = np.isfinite(err)
        kind = int(part[f"{method}: kind right"].sum())
        fp = int(part[f"{method}: false positives"].sum())
        med = f"{np.median(err[found]):.3g}" if found.any() else "-"
        return f"{method}: right kind first {kind}/{len(part)}, median error {med} ({int(found.sum())} found), FP {fp}"
    ours, naive = part["inference: error"].astype(float), part["naive: error"].astype(float)
    bounds = part["truth"].str.contains("<=|>=")
    close = np.isfinite(ours) & np.isfinite(naive) & (ours <= naive + 0.05)
    lowered = part["inference: lowered likelihood"].fillna(0).astype(int).sum()
    return (f"{summary('inference')}; {summary('naive')}; {summary('kkt')}; inference bound errors within 0.05 of "
            f"naive: {int((close & bounds).sum())}/{int(bounds.sum())}; accepted constraints that lowered the exact "
            f"likelihood: {lowered}")


def run(quick=False):
    os.environ.setdefault("TQDM_DISABLE", "1")
    from mutual.compendium.figures import markdown_table
    from mutual.compendium.paths import BUILD
    from mutual.constraints.continuous.benchmark import run_benchmark, summary_table
    start = time.perf_counter()
    frame = run_benchmark("all", quick=quick)
    wall = time.perf_counter() - start
    out = BUILD / "bench"
    out.mkdir(parents=True, exist_ok=True)
    frame.to_csv(out / "continuous-benchmark.csv", index=False)
    (out / "continuous-benchmark.md").write_text(markdown_table(summary_table(frame)) + "\n")
    rows = []
    for (split, system), part in frame.groupby(["split", "system"], sort=False):
        rows.append({"benchmark": "continuous constraint benchmark",
                     "case": f"{system}, {split} ({len(part)} cases, 20 demonstrations each; whole suite {wall:.0f} s)",
                     "seconds": float(part["inference: seconds"].sum()),
                     "baseline": "naive tightest bound / largest empty obstacle (KKT peer: see agreement)",
                     "baseline_seconds": float(part["naive: seconds"].sum()),
                     "compile_seconds": None, "agree": _agree(part) + f"; KKT seconds {part['kkt: seconds'].sum():.1f}",
                     "target": "", "met": None})
    return rows


if __name__ == "__main__":
    for row in run(quick=True):
        print(row)
