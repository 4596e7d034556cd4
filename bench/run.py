"""Run every benchmark (bench/bench_*.py) and print one table of timings and
ratios measured side by side, also written to figures/benchmarks.md.

Each module defines ``run(quick=False) -> list[dict]`` with rows
``{"benchmark", "case", "seconds", "baseline", "baseline_seconds", "compile_seconds", "agree",
"target", "met"}``: ``case`` names the problem and its size, ``baseline`` what a skilled
practitioner would use, ``compile_seconds`` the one-off compile time (excluded from ``seconds``),
``agree`` whether both give the same result and how that was checked.
Usage: ``python bench/run.py [--quick] [NAME ...]`` (NAME filters the modules).
"""

import argparse
import importlib.util
import platform
import sys

import pandas as pd

from mutual.atomic import write_text
from mutual.compendium.figures import markdown_table
from mutual.compendium.paths import ROOT, figures_dir

COLUMNS = ["benchmark", "case", "seconds", "baseline", "baseline_seconds", "ratio", "compile_seconds", "agree",
           "target", "met"]


def _load(path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def collect(quick, names):
    rows = []
    for path in sorted((ROOT / "bench").glob("bench_*.py")):
        if names and not any(n in path.stem for n in names):
            continue
        print(f"==> {path.stem}", flush=True)
        for row in _load(path).run(quick=quick):
            base = row.get("baseline_seconds")
            rows.append({**row, "ratio": base / row["seconds"] if base else None})
    return pd.DataFrame(rows, columns=COLUMNS)


def main(argv=None):
    parser = argparse.ArgumentParser(description="Run the compendium's benchmarks.")
    parser.add_argument("--quick", action="store_true", help="small sizes (smoke test)")
    parser.add_argument("names", nargs="*", help="only modules whose name contains one of these")
    args = parser.parse_args(argv)
    table = collect(args.quick, args.names)
    table["met"] = table["met"].map({True: "yes", False: "NO"}).fillna("")
    for col in ("baseline", "target", "agree"):
        table[col] = table[col].fillna("")
    text = markdown_table(table.astype(object).fillna(""), floatfmt=".3g")
    print(text)
    if not args.quick:
        header = (f"# Benchmarks\n\nMeasured by `make bench` on {platform.machine()} with "
                  f"{__import__('os').cpu_count()} cores, Python {platform.python_version()}. "
                  "`ratio` = baseline seconds / seconds (higher is faster).\n\n")
        print(f"wrote {write_text(figures_dir() / 'benchmarks.md', header + text)}")


if __name__ == "__main__":
    sys.exit(main())
