"""Numbers a notebook reproduces, written for the reproduction report.

Each notebook calls :func:`write_results` once with the claims it reproduces,
keyed by the ids of ``data/paper_claims.csv``; the file lands in
``<output folder>/results/<notebook-stem>.json`` with a record of the run that wrote it
(:mod:`.runs`). Every entry names the library function that computed it (``computed_by``) and
the computation (``note``). Timings never go here (they belong to ``make bench``), so the files
are identical on every rerun.
"""

import importlib
import json
import math
import numbers

import numpy as np

from ..atomic import write_text
from .claims import check_scan, load_claims
from .paths import results_dir, saved
from .runs import run_record


ROUNDOFF = 1e-12   # below this a difference of float64 results is rounding, not a result


def roundoff(value, floor=ROUNDOFF, fmt=".2g"):
    """``value`` as text that reads the same on every machine: ``"< 1e-12"`` when its magnitude is
    below ``floor`` (rounding noise, whose digits change with the CPU, the BLAS kernels and the
    thread count), else ``format(value, fmt)``. For gaps, residuals and checks that should be zero,
    in notes, tables and printed lines; ``floor`` sits well above the noise of the computation
    (``ROUNDOFF`` for float64 identities; a solver's tolerance for an optimiser's answer).
    NaN and infinity are refused (a check that produced them did not hold)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ValueError(f"roundoff: value must be a real number, got {value!r}")
    if not math.isfinite(value) or not (isinstance(floor, numbers.Real) and math.isfinite(floor) and floor > 0):
        raise ValueError(f"roundoff: value and floor must be finite (floor > 0), got {value!r} and {floor!r}")
    if abs(value) < floor:
        text = f"{floor:g}"
        if "e" in text:
            mantissa, exponent = text.split("e")
            text = f"{mantissa}e{int(exponent)}"
        return f"< {text}"
    return format(float(value), fmt)


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


def _plain_scan(cid, scan):
    """A claim's scan (:func:`mutual.compendium.claims.check_scan`) as JSON values."""
    if not isinstance(scan, dict):
        check_scan(cid, scan)
    scan = {k: (_plain(v) if k in ("seeds", "settings") and v is not None else v) for k, v in scan.items()}
    scan.setdefault("flips", "")
    return check_scan(cid, scan)


def import_dotted(dotted):
    """``(obj, None)`` for the module or attribute named by ``dotted`` (``a.b.c``), else ``(None, why)``."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        try:
            for attr in parts[cut:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return None, f"{'.'.join(parts[:cut])} has no {'.'.join(parts[cut:])}"
        return obj, None
    return None, "no importable module"


def resolve_computed_by(name):
    """The ``mutual`` function (or class, or method) named by the dotted ``name``; a ValueError
    says why when it is not one (machinery in ``mutual.compendium`` computes no claim)."""
    if not isinstance(name, str) or not name.startswith("mutual.") or name.startswith("mutual.compendium"):
        raise ValueError(f"computed_by {name!r} must name a library function of mutual, e.g. "
                         "'mutual.constraints.inference.greedy_inference' (not the compendium's machinery)")
    obj, why = import_dotted(name)
    if why:
        raise ValueError(f"computed_by {name!r}: {why}")
    if not callable(obj):
        raise ValueError(f"computed_by {name!r} is not a function or class")
    return obj


def _check_provenance(notebook, cid, entry):
    """Every entry names its computation: ``computed_by`` (a mutual function) and a ``note``."""
    for key in ("computed_by", "note"):
        if not str(entry.get(key, "")).strip():
            raise ValueError(f"notebook {notebook}, claim {cid!r}: the entry needs '{key}' "
                             "(computed_by: the mutual function that computed the value; note: the computation)")
    try:
        resolve_computed_by(entry["computed_by"])
    except ValueError as err:
        raise ValueError(f"notebook {notebook}, claim {cid!r}: {err}") from None


def _beside(notebook, cid, basis, beside):
    """The simulated value shown beside a row that is checked another way (:func:`write_results`)."""
    if basis == "original-data":
        raise ValueError(f"notebook {notebook}, claim {cid!r}: 'beside' is for a row checked another way (a thesis-numbers "
                         "row whose number also needs the study's data); an original-data row's own value is the "
                         "simulated one")
    if not isinstance(beside, dict) or set(beside) != {"value", "computed_by", "note"}:
        raise ValueError(f"notebook {notebook}, claim {cid!r}: 'beside' must be a dict with exactly 'value', "
                         f"'computed_by' and 'note', got {beside!r}")
    _check_provenance(notebook, f"{cid} (beside)", beside)
    return {"value": _plain(beside["value"]), "note": str(beside["note"]), "computed_by": str(beside["computed_by"])}


def simulated_beside(value, note, computed_by, prefix="SIMULATED: "):
    """A simulated value to stand beside a row whose own number needs the original data (the row's
    ``"beside"`` entry): ``{"value", "computed_by", "note"}``, the note led by ``prefix``."""
    return {"value": value, "computed_by": computed_by, "note": prefix + note}


def write_results(notebook, claims, simulated=False):
    """Write ``<output folder>/results/<notebook>.json`` from ``{claim_id: entry}``.

    Each entry is a dict with ``value``, ``computed_by`` (the dotted name of the library function
    that computed the value, e.g. ``mutual.constraints.inference.greedy_inference``; the notebook
    calls it), ``note`` (the computation: what was compared, on what), optionally ``simulated``
    (overriding the default for the whole notebook), for a ``computed`` claim ``scan``: the
    scan over what the thesis leaves open (:func:`mutual.compendium.claims.check_scan`), and
    ``beside``: for a row whose verdict comes from another check (a number re-derived from the thesis's
    own numbers) while the number itself needs the study's data, the value a SIMULATED study gives
    (a dict of ``value``, ``computed_by`` and ``note``); it is shown beside the row, labelled, and never
    decides its verdict (one number, one row). ``notebook`` is the notebook's file stem.
    Unknown claim ids and entries that do not name their computation raise a ValueError.
    """
    claims_table = load_claims()
    basis = dict(zip(claims_table["id"], claims_table["basis"]))
    entries = {}
    for cid, entry in sorted(claims.items()):
        if cid not in basis:
            raise ValueError(f"claim id {cid!r} (from notebook {notebook!r}) is not in data/paper_claims.csv")
        if not isinstance(entry, dict):
            raise ValueError(f"notebook {notebook}, claim {cid!r}: the entry must be a dict with 'value', "
                             f"'computed_by' and 'note', got {entry!r}")
        unknown = set(entry) - {"value", "simulated", "note", "computed_by", "scan", "beside"}
        if unknown or "value" not in entry:
            raise ValueError(f"notebook {notebook}, claim {cid!r}: entry needs 'value', 'computed_by' and 'note' "
                             f"and may carry 'simulated', 'scan' and 'beside', got {sorted(entry)}")
        _check_provenance(notebook, cid, entry)
        entries[cid] = {"value": _plain(entry["value"]),
                        "simulated": bool(entry.get("simulated", simulated)),
                        "note": str(entry["note"]),
                        "computed_by": str(entry["computed_by"])}
        if entry.get("scan") is not None:
            entries[cid]["scan"] = _plain_scan(cid, entry["scan"])
        if entry.get("beside") is not None:
            entries[cid]["beside"] = _beside(notebook, cid, basis[cid], entry["beside"])
    doc = {"notebook": notebook, "run": run_record(notebook), "claims": entries}
    return saved(write_text(results_dir() / f"{notebook}.json", json.dumps(doc, indent=1, sort_keys=True) + "\n"))


def write_extensions(notebook, results):
    """Write ``<output folder>/results/extensions/<notebook>.json``: numbers of an extension beyond the
    thesis (chapter 8's cycle, replication power), shown in the report's Extensions section and
    never counted among the thesis's verdicts.

    ``results`` maps a short key to a dict with ``statement`` (what was measured), ``value``,
    ``computed_by`` (the library function), and optionally ``note``, ``simulated`` (default True) and,
    for a claim of another publication checked here, its ``verdict`` by CLAIMS.md's rules.
    """
    from .claims import VERDICTS
    entries = {}
    for key, entry in sorted(results.items()):
        entry = dict(entry)
        missing = {"statement", "value", "computed_by"} - set(entry)
        unknown = set(entry) - {"statement", "value", "computed_by", "note", "simulated", "verdict"}
        if missing or unknown:
            raise ValueError(f"extension result {key!r}: needs 'statement', 'value' and 'computed_by' and may carry "
                             f"'note', 'simulated' and 'verdict' (missing {sorted(missing)}, unknown {sorted(unknown)})")
        if entry.get("verdict", VERDICTS[0]) not in VERDICTS:
            raise ValueError(f"extension result {key!r}: verdict {entry['verdict']!r} is not one of {list(VERDICTS)}")
        try:
            resolve_computed_by(entry["computed_by"])
        except ValueError as err:
            raise ValueError(f"notebook {notebook}, extension result {key!r}: {err}") from None
        entries[key] = {"statement": str(entry["statement"]), "value": _plain(entry["value"]),
                        "computed_by": str(entry["computed_by"]), "note": str(entry.get("note", "")),
                        "simulated": bool(entry.get("simulated", True)), "verdict": str(entry.get("verdict", ""))}
    doc = {"notebook": notebook, "run": run_record(notebook), "extensions": entries}
    text = json.dumps(doc, indent=1, sort_keys=True) + "\n"
    return saved(write_text(results_dir() / "extensions" / f"{notebook}.json", text))
