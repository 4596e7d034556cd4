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
