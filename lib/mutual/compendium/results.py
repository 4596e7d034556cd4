"""Numbers a notebook reproduces, written for the reproduction report.

Each notebook calls :func:`write_results` once with the claims it reproduces,
keyed by the ids of ``data/paper_claims.csv``; the file lands in
``figures/results/<notebook-stem>.json``. Timings never go here (they belong
to ``make bench``), so the files are identical on every rerun.
"""

import json
import math
import numbers

import numpy as np

from ..atomic import write_text
from .claims import load_claims
from .paths import results_dir


def _plain(value):
    """Convert numpy scalars and arrays into JSON values, rounding floats to 10 significant digits."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"result value {value!r} is not finite")
        return float(f"{value:.10g}")
    if isinstance(value, str):
        return value
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in np.asarray(value).tolist()]
    raise ValueError(f"result value {value!r} is not a number, boolean, string or list")


def write_results(notebook, claims, simulated=False):
    """Write ``figures/results/<notebook>.json`` from ``{claim_id: value or dict}``.

    A dict entry may carry ``value``, ``simulated`` (overriding the default for
    the whole notebook), ``note`` and ``computed_by`` (the dotted name of the library function
    that computed the value, e.g. ``mutual.constraints.inference.greedy_inference``).
    Unknown claim ids raise a ValueError.
    """
    known = set(load_claims()["id"])
    entries = {}
    for cid, entry in sorted(claims.items()):
        if cid not in known:
            raise ValueError(f"claim id {cid!r} (from notebook {notebook!r}) is not in data/paper_claims.csv")
        entry = dict(entry) if isinstance(entry, dict) else {"value": entry}
        unknown = set(entry) - {"value", "simulated", "note", "computed_by"}
        if unknown or "value" not in entry:
            raise ValueError(f"claim {cid!r}: entry needs 'value' and may carry only 'simulated', 'note' and "
                             f"'computed_by', got {sorted(entry)}")
        entries[cid] = {"value": _plain(entry["value"]),
                        "simulated": bool(entry.get("simulated", simulated)),
                        "note": str(entry.get("note", "")),
                        "computed_by": str(entry.get("computed_by", ""))}
    text = json.dumps({"notebook": notebook, "claims": entries}, indent=1, sort_keys=True) + "\n"
    return write_text(results_dir() / f"{notebook}.json", text)


def write_extensions(notebook, results):
    """Write ``figures/results/extensions/<notebook>.json``: numbers of an extension beyond the
    thesis (chapter 8's cycle, replication power), shown in the report's Extensions section and
    never counted among the thesis's verdicts.

    ``results`` maps a short key to a dict with ``statement`` (what was measured), ``value``,
    ``computed_by`` (the library function), and optionally ``note`` and ``simulated`` (default True).
    """
    entries = {}
    for key, entry in sorted(results.items()):
        entry = dict(entry)
        missing = {"statement", "value", "computed_by"} - set(entry)
        unknown = set(entry) - {"statement", "value", "computed_by", "note", "simulated"}
        if missing or unknown:
            raise ValueError(f"extension result {key!r}: needs 'statement', 'value' and 'computed_by' and may carry "
                             f"'note' and 'simulated' (missing {sorted(missing)}, unknown {sorted(unknown)})")
        entries[key] = {"statement": str(entry["statement"]), "value": _plain(entry["value"]),
                        "computed_by": str(entry["computed_by"]), "note": str(entry.get("note", "")),
                        "simulated": bool(entry.get("simulated", True))}
    text = json.dumps({"notebook": notebook, "extensions": entries}, indent=1, sort_keys=True) + "\n"
    return write_text(results_dir() / "extensions" / f"{notebook}.json", text)
