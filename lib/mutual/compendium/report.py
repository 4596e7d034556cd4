"""Build ``REPRODUCTION.md``: every claim of the thesis beside the value this code reproduces,
with a verdict (``python -m mutual.compendium.report [--output DIR] [--readme README.md]``).

The report refuses (a :class:`~mutual.compendium.runs.StaleResults` error naming the notebook;
non-zero exit) results older than their notebook, results whose notebook is gone and, when it
writes the committed ``figures/REPRODUCTION.md``, results of quick or custom runs.
"""

import argparse
import json
import os
import re
import sys
from pathlib import Path

import pandas as pd

from ..atomic import write_text
from .claims import VERDICTS, load_claims, load_settings, verdict
from .paths import OUTPUT_ENV, figures_dir, is_committed, results_dir
from .runs import check_record, shown

README_BEGIN = "<!-- verdict counts: written by `make figures` from figures/REPRODUCTION.md; a test checks they agree -->"
README_END = "<!-- /verdict counts -->"
_COUNT = re.compile(r"(\d+) (" + "|".join(map(re.escape, VERDICTS)) + r")\b")


def _documents(folder, kind):
    """``(path, doc)`` of every results file in ``folder`` (``kind``: ``claims`` or ``extensions``),
    each checked against its notebook (:func:`~mutual.compendium.runs.check_record`)."""
    committed = is_committed()
    docs = []
    for path in sorted(Path(folder).glob("*.json")):
        label = shown(path)
        try:
            doc = json.loads(path.read_text())
        except json.JSONDecodeError as err:
            raise ValueError(f"{label}: not a results file ({err})") from None
        if kind not in doc:
            raise ValueError(f"{label}: not a results file (no {kind!r})")
        doc["run"] = check_record(doc, label, committed)
        docs.append((path, doc))
    return docs


def load_results(folder=None):
    """Map claim id -> result entry (value, simulated, note, computed_by, notebook, mode) from every
    results file in ``folder`` (default: the output folder's ``results/``)."""
    found = {}
    known = set(load_claims()["id"])
    for path, doc in _documents(folder or results_dir(), "claims"):
        for cid, entry in doc["claims"].items():
            if cid not in known:
                raise ValueError(f"{path.name}: unknown claim id {cid!r} (not in data/paper_claims.csv)")
            if cid in found:
                raise ValueError(f"{path.name}: claim {cid!r} already reported by {found[cid]['notebook']}")
            found[cid] = dict(entry, notebook=doc["notebook"], mode=doc["run"]["mode"])
    return found


def extensions_table(folder=None):
    """One row per number of an extension beyond the thesis (``results/extensions/``)."""
    rows = []
    for path, doc in _documents(Path(folder or results_dir()) / "extensions", "extensions"):
        for key, e in doc["extensions"].items():
            rows.append({"notebook": doc["notebook"], "key": key, "measured": e["statement"], "value": _show(e["value"]),
                         "verdict": e.get("verdict", ""), "simulated": "yes" if e["simulated"] else "no",
                         "computed by": e["computed_by"], "note": e["note"]})
    return pd.DataFrame(rows, columns=["notebook", "key", "measured", "value", "verdict", "simulated", "computed by",
                                       "note"])


def _show(value):
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, list):
        return "[" + ", ".join(_show(v) for v in value) + "]"
    return str(value)


def _cell(text):
    return str(text).replace("|", "\\|").replace("\n", " ")


def _scan_text(scan):
    """A scan in a few words, with the table that shows it."""
    if not scan:
        return ""
    seeds = "no random draw" if scan.get("seeds") is None else "{}/{} seeds".format(*scan["seeds"])
    text = "{}; {}/{} settings (`{}`)".format(seeds, *scan["settings"], scan["table"])
    return text + (f"; flips: {scan['flips']}" if scan.get("flips") else "")


def _with_note(entry):
    """A result's value followed by its note and the function that computed it."""
    note = "; ".join(s for s in (entry.get("note", ""), entry.get("computed_by", "")) if s)
    return _show(entry["value"]) + (f" ({note})" if note else "")


def _reproduced(entry):
    """The reproduced cell: our value and, where the number itself needs the study's data, the value of a
    SIMULATED study beside it (it never decides the verdict)."""
    if not entry:
        return ""
    beside = entry.get("beside")
    return _with_note(entry) + (f"; beside it, SIMULATED: {_with_note(beside)}" if beside else "")


def _simulated(entry):
    if not entry:
        return ""
    return ("yes" if entry["simulated"] else "no") + ("; the value beside it: yes" if entry.get("beside") else "")


def report_table(folder=None):
    """One row per claim: the thesis value, the reproduced value, the scan and the verdict."""
    claims = load_claims()
    results = load_results(folder)
    rows = []
    for claim in claims.to_dict("records"):
        entry = results.get(claim["id"])
        got = entry["value"] if entry else None
        scan = entry.get("scan") if entry else None
        rows.append({"id": claim["id"], "chapter": int(claim["chapter"]), "section": claim["section"],
                     "lines": claim["lines"], "claim": claim["statement"], "thesis": claim["thesis_value"],
                     "reproduced": _reproduced(entry),
                     "scan": _scan_text(scan), "verdict": verdict(claim, got, scan),
                     "simulated inputs": _simulated(entry),
                     "figure": claim["figure"],
                     "run": (f"{entry['notebook']} ({entry['mode']})" if entry else "")})
    return pd.DataFrame(rows, columns=["id", "chapter", "section", "lines", "claim", "thesis", "reproduced", "scan",
                                       "verdict", "simulated inputs", "figure", "run"])


def summary_line(verdicts):
    """``Summary: N reproduced, N consistent, ... (of N claims).`` for a column of verdicts."""
    counts = pd.Series(verdicts).value_counts()
    return "Summary: " + ", ".join(f"{counts.get(v, 0)} {v}" for v in VERDICTS) + f" (of {len(verdicts)} claims)."


def summary_counts(text):
    """``{verdict: count}`` (every category, 0 where absent) and the claim total, read from the
    first summary line in ``text`` (a report or the README)."""
    line = next((ln for ln in text.splitlines() if ln.startswith("Summary: ")), None)
    if line is None:
        raise ValueError("no 'Summary: ...' line")
    counts = {v: 0 for v in VERDICTS}
    counts.update({v: int(n) for n, v in _COUNT.findall(line)})
    total = re.search(r"\(of (\d+) claims\)", line)
    return counts, int(total.group(1)) if total else None


def update_readme(readme, report_text):
    """Rewrite the summary line between the README's verdict-count markers from ``report_text``."""
    readme = Path(readme)
    text = readme.read_text()
    if README_BEGIN not in text or README_END not in text:
        raise ValueError(f"{readme}: no verdict-count markers ({README_BEGIN} ... {README_END})")
    line = next(ln for ln in report_text.splitlines() if ln.startswith("Summary: "))
    head, rest = text.split(README_BEGIN, 1)
    _, tail = rest.split(README_END, 1)
    new = f"{head}{README_BEGIN}\n{line}\n{README_END}{tail}"
    return write_text(readme, new) if new != text else readme


INTRO = [
    "# Reproduction report",
    "",
    "Every numeric or checkable claim of the thesis (`data/paper_claims.csv`) beside the value",
    "this compendium computes (`figures/results/*.json`, written by the notebooks), with the kind of",
    "evidence behind it. Regenerated by `make figures`; do not edit by hand.",
    "",
    "Verdicts: **reproduced** (our code ran the thesis's experiment with its method and a set-up fixed",
    "from its text, and the result holds for at least 9 of 10 seeds and across the scan of what the",
    "text leaves open), **verified** (a theorem, lemma or property checked by a route independent of",
    "the one it describes), **consistent** (re-derived from the thesis's own reported numbers),",
    "**holds by construction** (a check of our code against itself; listed apart, never counted as",
    "reproduced), **undetermined** (the outcome flips within the plausible range of something the",
    "thesis does not state; the row says where), **differs** (the statement fails across the whole",
    "plausible range, with our numerics ruled out), **not reproducible without the original data**",
    "(the study's human data; a simulated value may stand beside it), **pending** (no notebook",
    "reports it yet). One number, one row: where a number of the study is checked from the thesis's own",
    "numbers (consistent) but the number itself needs the study's data, the row says so and shows the value",
    "of a SIMULATED study beside it, labelled; that value never decides the verdict.",
    "",
]


def _markdown(table, head):
    return ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)] + [
        "| " + " | ".join(_cell(row[c]) for c in head) + " |" for _, row in table.iterrows()]


def _settings_section():
    settings = load_settings()
    return ["", "## Settings the thesis fixes", "",
            "Inputs, not claims: each is typed into the notebook that uses it, with the thesis lines that fix it.",
            ""] + _markdown(settings, ["id", "section", "lines", "setting", "value", "used_in"])


def build_report(folder=None):
    """Write the reproduction report into the output folder and return its path; results come from
    ``folder`` (default: the output folder's ``results/``)."""
    table = report_table(folder)
    modes = sorted({r.split(" (")[-1].rstrip(")") for r in table["run"] if r})
    head = ["id", "section", "lines", "claim", "thesis", "reproduced", "scan", "verdict", "simulated inputs", "figure"]
    own = table["verdict"] == "holds by construction"
    lines = INTRO + [summary_line(table["verdict"].tolist()), ""]
    if modes and modes != ["full"]:
        runs = sorted({r for r in table["run"] if r and not r.endswith("(full)")})
        lines += [f"**Not the committed report**: built in `{shown(figures_dir())}` from {', '.join(runs)}.", ""]
    lines += _markdown(table[~own], head)
    if own.any():
        lines += ["", "## Holds by construction", "",
                  "Checks of our own code against itself (a counter against the formula it implements, a solver",
                  "against its own closed form). They guard the code; they are not evidence about the thesis.", ""]
        lines += _markdown(table[own], [c for c in head if c not in ("scan", "simulated inputs")])
    lines += _settings_section()
    extensions = extensions_table(folder)
    if len(extensions):
        lines += ["", "## Extensions beyond the thesis", "",
                  "Numbers of experiments the thesis does not report (its closing cycle run end to end, replication",
                  "power, constraints from continuous demonstrations). They are not thesis claims and do not enter",
                  "the verdict counts above. A verdict here judges a claim of another publication the thesis cites",
                  "(its reference [67]), by the same rules, on our own set-up.", "",
                  "| " + " | ".join(extensions.columns) + " |", "|" + "---|" * len(extensions.columns)]
        lines += ["| " + " | ".join(_cell(v) for v in row) + " |" for row in extensions.itertuples(index=False)]
    return write_text(figures_dir() / "REPRODUCTION.md", "\n".join(lines) + "\n")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, help="output folder (default: $MUTUAL_OUTPUT_DIR, else build/scratch)")
    parser.add_argument("--readme", type=Path, help="README whose verdict counts to rewrite (committed report only)")
    args = parser.parse_args(argv)
    if args.output:
        os.environ[OUTPUT_ENV] = str(args.output.resolve())
    try:
        path = build_report()
        print(f"wrote {shown(path)}")
        if args.readme:
            if not is_committed():
                raise ValueError(f"--readme: the README states the committed report's counts; "
                                 f"{shown(path)} is not the committed figures/REPRODUCTION.md")
            print(f"wrote {shown(update_readme(args.readme, path.read_text()))}")
    except ValueError as err:
        sys.exit(f"reproduction report: {err}")


if __name__ == "__main__":
    main()
