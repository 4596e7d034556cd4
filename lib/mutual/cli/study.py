"""``mutual study``: the statistics of chapter 5 on any repeated-measures table.

``mutual study anova DATA.csv --dv COL --within COL --subject COL [--aggregate mean]`` runs the
one-way repeated-measures ANOVA of section 5.3.1 (:func:`mutual.study.rm_anova`) with the
Greenhouse-Geisser sphericity correction, all-pairs Tukey HSD with the repeated-measures error
term (:func:`mutual.study.tukey_rm`) and paired t-tests with Holm's correction
(:func:`mutual.study.paired_t_holm`; both in :func:`mutual.study.pairwise_comparisons`), on whatever
level names the ``--within`` column holds.
"""

import hashlib
import importlib
import json
import math
import re

from .. import budget
from . import common

#: Further ``mutual study`` subcommands: names of modules of ``mutual.cli`` that define
#: ``register(study_subparsers)``. The power analysis is wired with ``EXTENSIONS = ("power",)``.
EXTENSIONS = ("power",)

DESCRIPTION = """\
One-way repeated-measures ANOVA of --dv over the levels of --within, one row per --subject and
level (or several, averaged with --aggregate mean). Reports the ANOVA table (SS, df, MS, F, p), the
Greenhouse-Geisser epsilon and corrected p (sphericity), partial and generalized eta squared, Tukey
HSD for every pair of levels with the repeated-measures error term, and paired t-tests with Holm's
correction.

DATA.csv is any CSV table with a header; the study's tidy format (data/README.md) has one row per
participant x trial x measure, so select a measure with --where measure=trips and average a
participant's trials with --aggregate mean. Subject and level names are text exactly as written:
01 and 1 are two subjects, NA and None are names; names that differ only in surrounding spaces are
refused as ambiguous. Measured on the example (figures/benchmarks.md, a shared 2.3 GHz 2-core
machine): 2.5-3.3 s of CPU, most of it importing scipy.stats, pandas and matplotlib; no JAX.

writes to --out:  anova_<name>.csv (the test), pairwise_<name>.csv (Tukey and Holm),
                  cells_<name>.csv (the subject x level table analysed),
                  means_<name>.png (level means with SE bars and Tukey brackets; no brackets above
                  6 levels, no figure above 30: the tables hold them); <name>: --dv, then +COL=VALUE
                  per --where (value+measure=trips), with a hash of the request where they
                  hold characters other than A-Z a-z 0-9 _ . - or run past 80
"""

EXAMPLE = """\
example:
  mutual study anova data/examples/study.csv --dv value --within treatment \\
      --subject participant --where measure=false_positives --aggregate mean
"""


def register(subparsers):
    """Add ``mutual study`` and its subcommands (``anova``, then ``EXTENSIONS``)."""
    commands = common.command_group(subparsers, "study", "repeated-measures statistics of a user study (chapter 5)",
                                    "Statistics of a repeated-measures user study (chapter 5).")
    anova = common.add_command(commands, "anova", "repeated-measures ANOVA, Greenhouse-Geisser, Tukey and Holm",
                               DESCRIPTION, EXAMPLE)
    anova.add_argument("data", metavar="DATA.csv", help="a CSV table with a header row")
    anova.add_argument("--dv", required=True, metavar="COL",
                       help="the numeric column to analyse; in a tidy trial table (columns measure, value) "
                            "also a measure name, e.g. --dv false_positives")
    anova.add_argument("--within", required=True, metavar="COL",
                       help="the column naming each row's level (treatment/condition); any names")
    anova.add_argument("--subject", required=True, metavar="COL", help="the column naming each row's subject")
    anova.add_argument("--aggregate", choices=["mean"], default=None,
                       help="average several rows per subject and level (default: refuse them)")
    anova.add_argument("--where", action="append", default=[], metavar="COL=VALUE",
                       help="keep only rows whose COL equals VALUE (repeatable), e.g. measure=trips")
    anova.add_argument("--levels", metavar="A,B,...",
                       help="the levels to analyse and their order (default: every level, sorted)")
    common.add_output_options(anova)
    anova.set_defaults(handler=run_anova, prog=anova.prog)
    for name in EXTENSIONS:
        importlib.import_module(f"{__package__}.{name}").register(commands)


def _filters(where):
    pairs = []
    for item in where:
        column, sep, value = item.partition("=")
        if not sep or not column:
            raise common.InputError(f"--where {item!r}: expected COL=VALUE, e.g. measure=trips")
        pairs.append((column, value))
    return pairs


def _select(frame, args, path):
    """The rows and columns to analyse, with the file, column and line named on bad input."""
    from ..inputs import name_column, require_columns
    filters = _filters(args.where)
    if args.dv not in frame.columns and {"measure", "value"} <= set(frame.columns) \
            and (frame["measure"] == args.dv).any():
        # a tidy trial table: --dv names a measure, analysed in the column 'value'
        frame = frame[frame["measure"] == args.dv].rename(columns={"value": args.dv})
    with common.about(path):
        require_columns(frame, [args.dv, args.within, args.subject] + [c for c, _ in filters])
    for column, value in filters:
        keep = frame[column].fillna("") == value          # compared as text, as written
        if not keep.any():
            seen = sorted(frame[column].fillna("").unique().tolist())
            raise common.InputError(f"{path}: no row has {column} = {value!r} (column {column!r} holds "
                                    f"{[_shown(v) for v in seen[:12]]})")
        frame = frame[keep]
    with common.about(path):
        for column in (args.subject, args.within):
            name_column(frame, column, strip=False)      # empty names and names that differ only by spaces
    data = frame[[args.subject, args.within]]
    return data.assign(**{args.dv: common.numeric_column(frame, args.dv, path)})


def _shown(name, width=40):
    """A name for a message or a table: quoted as written, long ones cut with an ellipsis."""
    text = repr(name)
    return text if len(text) <= width else text[:width - 4] + "...'"


SAFE = re.compile(r"[A-Za-z0-9_.-]+")


def _stem(args):
    """The outputs' name: --dv, then +COL=VALUE for each --where (``value+measure=trips``) when every part is
    all A-Z a-z 0-9 _ . -; otherwise the parts cleaned to those characters plus a hash of the whole request.
    Parts cannot hold ``+`` or ``=``, so two requests never share file names (--dv score --where g=A and
    --dv score_A; --dv 'a b' and --dv 'a-b')."""
    filters = _filters(args.where)
    parts = [args.dv] + [f"{c}={v}" for c, v in filters]
    if all(SAFE.fullmatch(p) for p in [args.dv] + [x for pair in filters for x in pair]):
        stem = "+".join(parts)
        if len(stem) <= 80:
            return stem
    cleaned = "+".join(re.sub(r"[^A-Za-z0-9_.=-]+", "-", p).strip("-") or "x" for p in parts)[:80]
    request = json.dumps([args.dv, filters], ensure_ascii=False)
    return f"{cleaned}-{hashlib.sha256(request.encode()).hexdigest()[:8]}"


def analyse(data, dv, within, subject, aggregate=None, levels=None):
    """The ANOVA and the pairwise table of ``data`` as one results dict (the ``--json`` object)."""
    from ..study import pairwise_comparisons, rm_anova
    anova = rm_anova(data, dv=dv, within=within, subject=subject, aggregate=aggregate, levels=levels)
    pairwise = pairwise_comparisons(anova, undefined="leave")    # a pair without a t: noted, the rest tested
    undefined = [f"{_shown(a)} and {_shown(b)}: {why}" for (a, b), why in pairwise.attrs["undefined"].items()]
    notes = {} if not undefined else {"note_pairs": (
        f"no paired t-test for {len(undefined):,} of {len(pairwise):,} pairs (t, p_t and p_holm left empty; Holm "
        f"over the other {len(pairwise) - len(undefined):,}; Tukey's q is defined for every pair), "
        + ("e.g. " if len(undefined) > 1 else "") + undefined[0])}
    return anova, pairwise, {**notes,
        "dv": dv, "within": within, "subject": subject, "aggregate": aggregate,
        "n_subjects": anova.n_subjects, "levels": [str(level) for level in anova.levels],
        "means": {str(k): float(v) for k, v in anova.means.items()},
        "se": {str(k): v for k, v in anova.standard_errors().items()},
        "ss_effect": anova.ss_effect, "ss_error": anova.ss_error, "ss_subjects": anova.ss_subjects,
        "df1": anova.df1, "df2": anova.df2, "ms_effect": anova.ms_effect, "ms_error": anova.mse,
        "F": anova.F, "p": anova.p, "eps": anova.eps, "p_gg": anova.p_gg,
        "eta2p": anova.eta2p, "eta2g": anova.eta2g, "mse": anova.mse,
        "pairwise": [{k: str(v) if k in ("A", "B") else int(v) if k == "df" else float(v) for k, v in row.items()}
                     for row in pairwise.to_dict("records")],        # the table's numbers (Tukey's p once)
    }


MAX_PLOTTED_LEVELS = 30       # more bars than this are unreadable: the tables are written without the figure
MAX_BRACKETS = 15             # Tukey brackets drawn above the bars (all pairs of 6 levels); more hide the bars
MAX_PRINTED_PAIRS = 45        # pairs listed in the summary (all pairs of 10 levels); the CSV has every pair

TABLE_COLUMNS = ("dv", "within", "subject", "n_subjects", "ss_effect", "ss_error", "ss_subjects", "df1", "df2",
                 "ms_effect", "ms_error", "F", "p", "eps", "p_gg", "eta2p", "eta2g", "mse")


def run_anova(args):
    path = common.existing_file(args.data)
    wanted = {args.dv, args.within, args.subject, "measure", "value"} | {c for c, _ in _filters(args.where)}
    frame = common.read_csv(path, keep=wanted)           # the other columns are never made into a table
    data = _select(frame, args, path)
    levels = None
    if args.levels:
        levels = [s.strip() for s in args.levels.split(",") if s.strip()]
        present = sorted(set(data[args.within]))
        absent = [level for level in levels if level not in present]
        if absent:
            raise common.InputError(f"{path}: --levels: no row has {args.within} = {_shown(absent[0])} "
                                    f"(column {args.within!r} holds {[_shown(v) for v in present[:12]]})")
        data = data[data[args.within].isin(levels)]
    k, n = data[args.within].nunique(), data[args.subject].nunique()
    budget.check(budget.anova(k, n, len(data)))   # before any pair is tested: 1000 levels are 499,500 pairs
    with common.about(path):
        try:
            anova, pairwise, results = analyse(data, args.dv, args.within, args.subject, args.aggregate, levels)
        except ValueError as err:      # speak the command line's words, not the library's
            raise type(err)(str(err).replace("aggregate='mean'", "--aggregate mean")) from None
    results = {"command": "study anova", "input": str(path), "where": dict(_filters(args.where)), **results}
    if not all(0 < abs(results[k]) < math.inf for k in ("ss_error", "ms_error")):
        results["note"] = ("the sums and mean squares of data this large or small are beyond the range of doubles "
                           "(null or 0 here); F, p, eps and eta squared were computed in scaled units and are exact")

    import pandas as pd
    stem = _stem(args)
    table = pd.DataFrame([{k: results[k] for k in TABLE_COLUMNS}])
    with common.output_set(args) as files:
        outputs = {"anova": files.csv(table, f"anova_{stem}.csv"),
                   "pairwise": files.csv(pairwise, f"pairwise_{stem}.csv"),
                   "cells": files.csv(anova.cells.reset_index(), f"cells_{stem}.csv")}
        if len(anova.levels) <= MAX_PLOTTED_LEVELS:
            outputs["figure"] = files.figure(_figure(anova, pairwise, args), f"means_{stem}.png")
        else:
            results["note_figure"] = (f"no figure: {len(anova.levels):,} levels are more than the {MAX_PLOTTED_LEVELS} "
                                      "a readable bar chart holds; the tables have every level and pair")
    results["outputs"] = {k: str(v) for k, v in outputs.items()}
    common.report(args, _summary(results, args), results)


def _figure(anova, pairwise, args):
    common.use_agg()
    import matplotlib.pyplot as plt
    from ..study import plot_condition_means
    anova, unit = _plotted(anova)
    fig, ax = plt.subplots(figsize=(1.6 + 1.1 * len(anova.levels), 3.4))
    brackets = pairwise.rename(columns={"p_tukey": "p"}) if len(pairwise) <= MAX_BRACKETS else None
    plot_condition_means(ax, anova, brackets)
    low, top = float(anova.cells.to_numpy().min()), ax.get_ylim()[1]
    if low < 0:                                   # the bars start at 0; show negative values too
        ax.set_ylim(low - 0.05 * (top - low), top)
    selected = ", ".join(v for _, v in _filters(args.where))
    ax.set_xlabel(_cut(args.within))
    ax.set_ylabel(_cut(f"{selected} ({args.dv})" if selected else args.dv) + unit
                  + ("\nmean per subject and level" if args.aggregate else ""))
    # the title in lines no wider than the axes (a long one was cut at the figure's right edge)
    pairs = "brackets: Tukey HSD p" if brackets is not None else f"{len(pairwise)} pairs: Tukey HSD p in the pairwise table"
    from ..study import MAX_SUBJECT_LINES
    grey = "grey: subjects" if anova.n_subjects <= MAX_SUBJECT_LINES else \
        f"subjects not drawn (more than {MAX_SUBJECT_LINES})"
    ax.set_title(f"means with standard-error bars (n = {anova.n_subjects})\n{grey}; {pairs}", fontsize=8)
    return fig


def _plotted(anova):
    """The ANOVA to draw, in units of 10^k when its values are too large or small for an axis (1e308 overflows
    matplotlib's tick arithmetic), and the unit's label."""
    import dataclasses
    top = float(abs(anova.cells.to_numpy()).max())
    if top == 0 or 1e-100 < top < 1e100:
        return anova, ""
    k = math.floor(math.log10(top))
    cells = anova.cells / 10.0 ** k
    means = {level: float(cells[level].mean()) for level in anova.levels}
    return dataclasses.replace(anova, cells=cells, means=means), f" (x 1e{k})"


def _cut(text, width=60):
    return text if len(text) <= width else text[:width - 1] + "\u2026"


def _summary(r, args):
    where = ", ".join(f"{c} = {v}" for c, v in r["where"].items())
    lines = [f"Repeated-measures ANOVA of {r['dv']!r}" + (f" ({where})" if where else "")
             + f" over {r['within']!r}, {r['n_subjects']} subjects"
             + (" (cells: mean of each subject's rows)" if r["aggregate"] else ""), ""]
    names = {level: _shown(level)[1:-1] for level in r["levels"]}     # as written, long ones cut
    width = max(len(name) for name in names.values()) + 2
    lines.append(f"  {'level':<{width}}{'mean':>11}{'SE':>11}")
    for level in r["levels"]:
        lines.append(f"  {names[level]:<{width}}{r['means'][level]:>11.4g}{r['se'][level]:>11.3g}")
    source = _cut(r["within"], 16)
    lines += ["", f"  {'source':<18}{'SS':>11}{'df':>5}{'MS':>11}{'F':>10}{'p':>11}{'eps':>7}{'p_GG':>11}"
                  f"{'eta2p':>7}{'eta2G':>7}",
              f"  {source:<18}{r['ss_effect']:>11.4g}{r['df1']:>5}{r['ms_effect']:>11.4g}{r['F']:>10.4g}{r['p']:>11.4g}"
              f"{r['eps']:>7.3f}{r['p_gg']:>11.4g}{r['eta2p']:>7.3f}{r['eta2g']:>7.3f}",
              f"  {'error':<18}{r['ss_error']:>11.4g}{r['df2']:>5}{r['ms_error']:>11.4g}",
              f"  {'subjects':<18}{r['ss_subjects']:>11.4g}{r['n_subjects'] - 1:>5}", ""]
    lines += [f"  F({r['df1']}, {r['df2']}) = {r['F']:.4g}, p = {r['p']:.4g}; Greenhouse-Geisser epsilon = "
              f"{r['eps']:.3f}, corrected p = {r['p_gg']:.4g}",
              f"  partial eta squared = {r['eta2p']:.3f}, generalized eta squared = {r['eta2g']:.3f}"]
    if "note" in r:
        lines.append(f"  ({r['note']})")
    lines += ["", "  pairwise: Tukey HSD (repeated-measures error term) and paired t-tests (Holm-corrected)",
              f"  {'A':<{width}}{'B':<{width}}{'diff':>10}{'q':>8}{'p Tukey':>10}{'t':>8}{'p Holm':>10}"]
    for row in r["pairwise"][:MAX_PRINTED_PAIRS]:
        t, p_holm = (f"{row['t']:>8.3g}", f"{row['p_holm']:>10.4g}") if math.isfinite(row["t"]) else (f"{'-':>8}", f"{'-':>10}")
        lines.append(f"  {names[row['A']]:<{width}}{names[row['B']]:<{width}}{row['diff']:>10.4g}{row['q']:>8.3g}"
                     f"{row['p_tukey']:>10.4g}{t}{p_holm}")
    if len(r["pairwise"]) > MAX_PRINTED_PAIRS:
        lines.append(f"  ... the first {MAX_PRINTED_PAIRS} of {len(r['pairwise']):,} pairs; every pair is in "
                     f"{r['outputs']['pairwise']}")
    for note in ("note_pairs", "note_figure"):
        if note in r:
            lines += ["", f"  ({r[note]})"]
    lines += ["", "wrote " + ", ".join(r["outputs"].values())]
    return "\n".join(lines)
