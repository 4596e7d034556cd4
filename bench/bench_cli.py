"""Command-line latency (issue 23, section 2): each ``mutual`` command on its example in data/examples/,
as a user runs it (a fresh process of the installed console script), once the environment is warm.

``seconds`` is the median wall time of the measured runs after one warm-up run (the warm-up fills the OS
file cache, the value-function and JAX compilation caches); the case also gives the median CPU time of
the process and its children, which a shared machine's load inflates far less than the wall time (on a
quiet core the wall time is about the CPU time). What the time went to is measured apart:
``python -X importtime`` of the same command gives the seconds spent importing (and the heaviest
top-level packages); the rest is the interpreter's start, the computation and the writing of the outputs.
Target: under 1.5 s for the commands that only do statistics or print help; the others really compute
(an LQR or iLQR solve, constraint inference, value functions, simulated cohorts) and say what.

Full: 3 measured runs per command, and the SIMULATED power sweep from a warm cache; quick: 1 run,
without the sweep.
"""

import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "data" / "examples"
TARGET = 1.5

#: (name, arguments after `mutual`, what it computes, or None for a statistics/help command held to TARGET)
COMMANDS = [
    ("mutual --help", ["--help"], None),
    ("mutual study anova", ["study", "anova", EXAMPLES / "study.csv", "--dv", "value", "--within", "treatment",
                            "--subject", "participant", "--where", "measure=false_positives", "--aggregate", "mean"],
     None),
    ("mutual study power --analytic-only", ["study", "power", "--analytic-only"], None),
    ("mutual study power --f", ["study", "power", "--f", "0.25", "--m", "3", "--rho", "0.5", "--power", "0.95"], None),
    ("mutual motion legible", ["motion", "legible", EXAMPLES / "legible.toml"],
     "computes: the receding-horizon LQR of Fig. 6.2 (JAX, compiled once per process from the persistent cache)"),
    ("mutual constraints infer", ["constraints", "infer", EXAMPLES / "demonstrations.csv", "--world",
                                  EXAMPLES / "world.toml"], "computes: Algorithm 4's greedy inference (JAX)"),
    ("mutual supervisor fit", ["supervisor", "fit", EXAMPLES / "interventions.csv", "--method", "closed-form"],
     "computes: closed-form value functions of 12 Dubins cars and three ML fits"),
]
SWEEP = ("mutual study power (simulated, cached)", ["study", "power", "--quick", "--inline", "--n", "6", "8",
                                                    "--cohorts", "4"],
         "computes: loads chapter 4's value functions (JAX) and 4 SIMULATED cohorts from the cache")


def _command(argv, out, importtime=False):
    script = Path(sys.executable).with_name("mutual")
    head = [sys.executable, "-X", "importtime", "-m", "mutual.cli"] if importtime or not script.exists() else [str(script)]
    tail = [] if argv == ["--help"] else ["--no-progress", "--out", str(out)]
    return head + [str(a) for a in argv] + tail


def _cpu():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _run(argv, out, importtime=False):
    """Wall and CPU seconds of one run of ``mutual argv`` in a fresh process, and its stderr."""
    start, cpu = time.perf_counter(), _cpu()
    done = subprocess.run(_command(argv, out, importtime), capture_output=True, text=True, timeout=900, cwd=out,
                          env={**os.environ, "TQDM_DISABLE": "1"})
    seconds, cpu = time.perf_counter() - start, _cpu() - cpu
    if done.returncode != 0:
        raise RuntimeError(f"mutual {' '.join(map(str, argv))} failed: {done.stderr.strip()[-300:]}")
    return seconds, cpu, done.stderr


def _imports(argv, out):
    """Seconds spent importing, and the three packages that took most of it (each module's own time, summed
    by top-level package), from ``python -X importtime``."""
    top = {}
    for line in _run(argv, out, importtime=True)[2].splitlines():
        match = re.match(r"import time:\s+(\d+) \|\s+\d+ \| +(\S+)$", line)
        if match:
            name = match.group(2).split(".")[0]
            top[name] = top.get(name, 0) + int(match.group(1)) / 1e6
    heavy = sorted(top.items(), key=lambda kv: -kv[1])[:3]
    return sum(top.values()), ", ".join(f"{k} {v:.2f} s" for k, v in heavy)


def _row(name, argv, computes, runs):
    with tempfile.TemporaryDirectory(prefix="bench-cli-") as out:
        _run(argv, Path(out))                                   # warm-up
        measured = [_run(argv, Path(out))[:2] for _ in range(runs)]
        imports, heavy = _imports(argv, Path(out))
    wall, cpu = statistics.median(w for w, _ in measured), statistics.median(c for _, c in measured)
    case = (f"example in data/examples/; median of {runs}: {wall:.2f} s wall, {cpu:.2f} s CPU (what a quiet core "
            f"takes); imports {imports:.2f} s ({heavy}), the rest start-up, work and outputs")
    return {"benchmark": f"CLI: {name}", "case": case, "seconds": wall, "baseline": "", "baseline_seconds": None,
            "compile_seconds": None, "agree": "",
            "target": computes or f"< {TARGET:g} s wall, warm, no JAX imported",
            "met": None if computes else bool(wall < TARGET and "jax" not in heavy)}


def run(quick=False):
    runs = 1 if quick else 3
    commands = COMMANDS + ([] if quick else [SWEEP])
    return [_row(name, argv, computes, runs) for name, argv, computes in commands]


if __name__ == "__main__":
    for row in run(quick="--quick" in sys.argv):
        print(f"{row['benchmark']:<48}{row['seconds']:7.2f} s  {row['case']}")
