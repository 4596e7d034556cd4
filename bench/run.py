"""Run every benchmark (bench/bench_*.py) and print one table of timings and ratios measured side by
side, with the machine and the versions they were measured on.

Each module defines ``run(quick=False) -> list[dict]`` with rows
``{"benchmark", "case", "seconds", "baseline", "baseline_seconds", "compile_seconds", "agree",
"target", "met"}``: ``case`` names the problem and its size, ``baseline`` what a skilled
practitioner would use, ``compile_seconds`` the one-off compile time (excluded from ``seconds``),
``agree`` whether both give the same result and how that was checked.

Usage: ``python bench/run.py [--quick] [--peers] [--out PATH] [NAME ...]`` (NAME filters the modules).
Only a full run of every module writes the committed ``figures/benchmarks.md``; a quick or filtered
run writes ``build/bench/benchmarks-quick.md`` / ``benchmarks-partial.md``. A module that fails is
reported in the table and makes the exit status non-zero; the others still run.

``--peers`` (``make bench-peers``, in its own environment) runs ``bench/peers/bench_*.py`` instead:
our solvers against crocoddyl, CasADi + IPOPT and pingouin. Its table is a section of the same
file, between ``<!-- peers: begin -->`` and ``<!-- peers: end -->``; each run replaces only its own
part of the file, so ``make bench`` keeps the peers' section and ``make bench-peers`` the rest.
"""

import argparse
import datetime
import importlib.metadata
import importlib.util
import os
import platform
import re
import subprocess
import sys
import time
import traceback
from pathlib import Path

import pandas as pd

from mutual.atomic import write_text
from mutual.compendium.figures import markdown_table
from mutual.compendium.paths import BUILD, FIGURES, ROOT

BENCH = ROOT / "bench"
COLUMNS = ["benchmark", "case", "seconds", "baseline", "baseline_seconds", "ratio", "compile_seconds", "agree",
           "target", "met"]
SHOWN = {"case": "case (problem, size)", "baseline_seconds": "baseline seconds", "compile_seconds": "compile seconds",
         "agree": "agreement (how checked)"}
VERSIONS = ["numpy", "scipy", "jax", "jaxlib", "optax", "pandas", "cvxpy", "hj-reachability", "statsmodels"]
PEER_VERSIONS = ["crocoddyl", "casadi", "pingouin"]
PEERS = "peers"  # the name of the peers' section of the file
SECTION = re.compile(r"<!-- (?P<name>[\w-]+): begin -->\n.*?<!-- (?P=name): end -->\n?", re.S)
BUDGET = {True: 180, False: 1200}  # seconds: quick mode, full run (2 cores)


def machine():
    """The machine the timings were measured on, and its load when the run started."""
    model = next((line.split(":", 1)[1].strip() for line in _read("/proc/cpuinfo").splitlines()
                  if line.startswith("model name")), platform.processor() or platform.machine())
    memory = next((int(line.split()[1]) / 2**20 for line in _read("/proc/meminfo").splitlines()
                   if line.startswith("MemTotal")), None)
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    load = ", ".join(f"{v:.2f}" for v in os.getloadavg())
    threads = ", ".join(f"{k}={os.environ[k]}" for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS") if k in os.environ)
    return {"cpu": f"{model} ({platform.machine()})", "cores": f"{usable} usable of {os.cpu_count()}",
            "memory": f"{memory:.1f} GiB" if memory else "unknown", "load average at start (1, 5, 15 min)": load,
            "threads": threads or "library defaults",
            "XLA_FLAGS": os.environ.get("XLA_FLAGS", "") or "none (importing mutual sets one: mutual.xla_cpu)"}


def versions(names=VERSIONS):
    found = {"python": platform.python_version()}
    for name in names:
        try:
            found[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            found[name] = "not installed"
    return found


def _read(path):
    try:
        return Path(path).read_text()
    except OSError:
        return ""


def _commit():
    try:
        out = subprocess.run(["git", "-C", str(ROOT), "describe", "--always", "--dirty"], capture_output=True,
                             text=True, timeout=10)
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.TimeoutExpired):
        return "unknown"


def _load(path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def collect(quick, names, folder=BENCH):
    """Rows of every module (``bench_*.py`` in ``folder`` whose name contains one of ``names``), the
    wall time per module, and the modules that failed (name -> one-line error)."""
    rows, walls, failed = [], {}, {}
    for path in sorted(Path(folder).glob("bench_*.py")):
        if names and not any(n in path.stem for n in names):
            continue
        print(f"==> {path.stem}", flush=True)
        start = time.perf_counter()
        try:
            produced = _load(path).run(quick=quick)
            for row in produced:
                missing = {"benchmark", "case", "seconds"} - set(row)
                if missing:
                    raise ValueError(f"a row lacks {sorted(missing)}: {row}")
                base = row.get("baseline_seconds")
                rows.append({**row, "ratio": base / row["seconds"] if base and row["seconds"] else None})
        except Exception as err:  # noqa: BLE001 (one module's failure must not hide the others' rows)
            failed[path.stem] = f"{type(err).__name__}: {err}"
            traceback.print_exc()
            rows.append({"benchmark": path.stem, "case": "FAILED: " + failed[path.stem], "seconds": None})
        walls[path.stem] = time.perf_counter() - start
        print(f"    {walls[path.stem]:.1f} s", flush=True)
    return pd.DataFrame(rows, columns=COLUMNS), walls, failed


def gaps(table):
    """Rows that do not state what the table promises (a baseline time, how agreement was checked)."""
    out = []
    for row in table.itertuples(index=False):
        has_baseline = isinstance(row.baseline, str) and row.baseline.strip()
        if has_baseline and pd.isna(row.baseline_seconds):
            out.append(f"{row.benchmark} / {row.case}: names a baseline but no baseline time")
        if has_baseline and not (isinstance(row.agree, str) and row.agree.strip()):
            out.append(f"{row.benchmark} / {row.case}: does not say whether the results agree or how that was checked")
    return out


def render(table, walls, failed, quick, names, started, total, host, peers=False):
    shown = table.copy()
    shown["met"] = shown["met"].map({True: "yes", False: "NO"}).fillna("")
    shown["compile_seconds"] = shown["compile_seconds"].astype(object).where(shown["compile_seconds"].notna(), "-")
    shown = shown.astype(object).where(shown.notna(), "").rename(columns=SHOWN)
    mode = "quick (small sizes)" if quick else "full"
    target, h = ("bench-peers", "###") if peers else ("bench", "##")
    lines = ["## Against the peers (`make bench-peers`)" if peers else "# Benchmarks", "",
             f"Measured by `make {target}{' QUICK=1' if quick else ''}` ({mode}"
             f"{', modules: ' + ', '.join(names) if names else ''}) on {started:%Y-%m-%d %H:%M} UTC at commit "
             f"`{_commit()}`, in {total:.0f} s{PEERS_ENVIRONMENT if peers else ''}.",
             "`ratio` = baseline seconds / seconds (higher is faster); `compile seconds` is the one-off compile time,",
             "excluded from `seconds`; `-` where the row reports none.", "", f"{h} Machine", ""]
    lines += [f"- {k}: {v}" for k, v in host.items()]
    lines += ["", f"{h} Versions", "",
              "- " + ", ".join(f"{k} {v}" for k, v in versions(VERSIONS + PEER_VERSIONS * peers).items()), "",
              f"{h} Timings", "", markdown_table(shown, floatfmt=".3g").rstrip(), "",
              "Wall time per module: " + ", ".join(f"{k} {v:.0f} s" for k, v in walls.items()) + "."]
    notes = gaps(table)
    if notes:
        lines += ["", "Rows that do not state everything the table promises:", ""] + [f"- {n}" for n in notes]
    if failed:
        lines += ["", "Modules that failed:", ""] + [f"- {k}: {v}" for k, v in failed.items()]
    if total > BUDGET[quick]:
        lines += ["", f"Over budget: {total:.0f} s (budget {BUDGET[quick]} s for a {mode} run on 2 cores)."]
    return "\n".join(lines) + "\n"


PEERS_ENVIRONMENT = (", in the peers' environment (`.venv-peers`, from `bench/peers/requirements.lock`; the "
                     "packages it shares with `environment.lock` at the same versions)")


def default_output(quick, names, peers=False):
    """Only a full run of every module writes the committed table."""
    prefix = "peers" if peers else "benchmarks"
    if quick:
        return BUILD / "bench" / f"{prefix}-quick.md"
    return BUILD / "bench" / f"{prefix}-partial.md" if names else FIGURES / "benchmarks.md"


def merge(old, new, section=None):
    """The text of the benchmarks file after a run: ``new`` replaces the main part (``section``
    None) or the named section of ``old``, and every other part of ``old`` is kept. Sections sit
    after the main part, each between ``<!-- NAME: begin -->`` and ``<!-- NAME: end -->``."""
    sections = {m["name"]: m[0].rstrip() + "\n" for m in SECTION.finditer(old)}
    main = SECTION.sub("", old).rstrip()
    if section is None:
        main = new.rstrip()
    else:
        sections[section] = f"<!-- {section}: begin -->\n{new.rstrip()}\n<!-- {section}: end -->\n"
    parts = [main + "\n"] if main else []
    return "\n".join(parts + list(sections.values()))


def main(argv=None):
    parser = argparse.ArgumentParser(description="Run the compendium's benchmarks.")
    parser.add_argument("--quick", action="store_true", help="small sizes (under 3 minutes); never writes figures/")
    parser.add_argument("--peers", action="store_true",
                        help="the peers (bench/peers/: crocoddyl, CasADi, pingouin), in their own environment")
    parser.add_argument("--out", type=Path, help="where to write the table (default: see the module docstring)")
    parser.add_argument("--modules", type=Path, default=BENCH, help=argparse.SUPPRESS)
    parser.add_argument("names", nargs="*", help="only modules whose name contains one of these")
    args = parser.parse_args(argv)
    host = machine()  # before the run: the load average at its start
    started, start = datetime.datetime.now(datetime.timezone.utc), time.perf_counter()
    folder = BENCH / PEERS if args.peers and args.modules == BENCH else args.modules
    table, walls, failed = collect(args.quick, args.names, folder)
    text = render(table, walls, failed, args.quick, args.names, started, time.perf_counter() - start, host,
                  args.peers)
    print(text)
    out = args.out or default_output(args.quick, args.names, args.peers)
    old = out.read_text() if out.exists() else ""
    print(f"wrote {write_text(out, merge(old, text, PEERS if args.peers else None))}")
    if failed:
        print(f"benchmarks failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
