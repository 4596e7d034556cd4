"""The thesis's numeric and checkable claims (``data/paper_claims.csv``), the settings the
thesis fixes (``data/paper_settings.csv``), and the rules that turn a computed value into a
verdict a reader can trust (the README's "What reproduces" defines each verdict).

Claim columns: ``id`` (``c<chapter>-<slug>``), ``chapter``, ``section``, ``lines`` (the thesis
text's lines that state the claim), ``statement``, ``thesis_value``, ``compare``, ``basis`` and
``figure``.

``basis`` says what kind of evidence stands behind our value, and so which verdicts it can earn:

* ``computed`` -- our code ran the thesis's experiment with its method and a set-up fixed from
  its text. The entry carries its *scan* over what the text leaves open (:func:`check_scan`):
  **reproduced** when the rule holds at the chosen set-up, for at least 9 of 10 seeds and in every
  cell of the scan; **differs** when it fails everywhere; otherwise **undetermined** (the row says
  where it flips);
* ``independent`` -- a theorem, lemma or property of the thesis checked by a route independent of
  the one the statement describes (brute force, a generic optimiser on the raw objective, finite
  differences, an exact solution): **verified** when the rule holds, else **differs**;
* ``thesis-numbers`` -- re-derived from numbers the thesis reports: **consistent**, else **differs**;
* ``construction`` -- a check of our code against itself (a counter that adds the terms of the
  formula it checks, a solver against its own closed form): **holds by construction**, listed apart
  and never counted as reproduced; a failing one is a bug of ours and stops the report;
* ``undetermined`` -- the thesis does not give what the number depends on; the value is the range
  ``[low, high]`` over the plausible choices: **undetermined**;
* ``original-data`` -- needs the thesis's human data: **not reproducible without the original
  data**; a value computed on simulated data may be shown beside it.

``compare`` is the rule: ``abs:TOL`` / ``rel:TOL`` (numeric, |got - thesis| <= TOL, or
<= TOL * |thesis|), ``>=`` / ``<=`` (a bound on got), ``true`` (a check that reports True or
False), ``range`` (undetermined rows) or ``none`` (original-data rows).

A setting (100 demonstrations, psi = 0.25) is not a claim: ``data/paper_settings.csv`` lists each
with the thesis lines that fix it (columns ``id``, ``chapter``, ``section``, ``lines``,
``setting``, ``value``, ``used_in``).
"""

import math
import re

from ..inputs import line_of, place, read_csv
from . import paths

COLUMNS = ["id", "chapter", "section", "lines", "statement", "thesis_value", "compare", "basis", "figure"]
SETTING_COLUMNS = ["id", "chapter", "section", "lines", "setting", "value", "used_in"]
BASES = ("computed", "independent", "thesis-numbers", "construction", "undetermined", "original-data")
VERDICTS = ("reproduced", "verified", "consistent", "holds by construction", "undetermined", "differs",
            "not reproducible without the original data", "pending")
ROBUST_SEEDS = 0.9  # "reproduced" needs the statement to hold for at least 9 of 10 seeds (CLAIMS.md rule 2)
MIN_SEEDS = 10
_SHARE = re.compile(r"\b(p|p-value|probability|probabilities|rate|fraction|share|proportion)\b|%", re.I)
_CHECKS = ("abs", "rel", ">=", "<=", "true")
_RULES = {"computed": _CHECKS, "independent": _CHECKS, "thesis-numbers": _CHECKS, "construction": _CHECKS,
          "undetermined": ("range",), "original-data": ("none",)}
_PASS = {"independent": "verified", "thesis-numbers": "consistent", "construction": "holds by construction"}


def _read_table(path, columns, kind):
    """A table of text cells (empty ones "") with ``columns`` and unique ids, or a ValueError naming the file
    and the line (:func:`mutual.inputs.read_csv`)."""
    df = read_csv(path, columns).fillna("")
    dup = df["id"].duplicated().to_numpy()
    if dup.any():
        again = df.index[dup][0]
        first = df.index[(df["id"] == df["id"].loc[again]).to_numpy()][0]
        raise ValueError(f"{place(df, again, 'id')}: the {kind} id {df['id'].loc[again]!r} appears again (first on "
                         f"line {line_of(df, first)}); each {kind} needs its own id")
    return df


def load_claims(path=None):
    """Read and validate the claims table (default ``data/paper_claims.csv``)."""
    path = path or paths.CLAIMS
    df = _read_table(path, COLUMNS, "claim")
    for claim in df.to_dict("records"):
        _parse_rule(claim)
    return df


def load_settings(path=None):
    """Read and validate the settings table (default ``data/paper_settings.csv``): every setting
    names the thesis lines that fix it."""
    path = path or paths.SETTINGS
    df = _read_table(path, SETTING_COLUMNS, "setting")
    unsourced = df["id"][df["lines"].str.strip() == ""].tolist()
    if unsourced:
        raise ValueError(f"{path}: settings {unsourced} name no thesis lines")
    return df


def _parse_rule(claim):
    cid, rule, basis = claim["id"], claim["compare"], claim["basis"]
    if basis not in BASES:
        raise ValueError(f"claim {cid!r}: basis {basis!r} is not one of {BASES}")
    kind, _, tol = rule.partition(":")
    if kind not in _RULES[basis]:
        raise ValueError(f"claim {cid!r}: compare rule {rule!r} does not fit basis {basis!r} "
                         f"(allowed: {', '.join(_RULES[basis])})")
    if kind in ("abs", "rel"):
        try:
            return kind, float(tol)
        except ValueError:
            raise ValueError(f"claim {cid!r}: compare rule {rule!r} needs a numeric tolerance") from None
    if tol:
        raise ValueError(f"claim {cid!r}: compare rule {rule!r} takes no tolerance")
    return kind, None


def _number(claim, got):
    if isinstance(got, bool) or not isinstance(got, (int, float)):
        raise ValueError(f"claim {claim['id']!r}: rule {claim['compare']!r} needs a number, got {got!r}")
    return float(got)


def _holds(claim, got):
    """Whether our value satisfies the claim's rule."""
    kind, tol = _parse_rule(claim)
    if kind == "true":
        if not isinstance(got, bool):
            raise ValueError(f"claim {claim['id']!r}: rule 'true' needs a boolean result, got {got!r}")
        return got
    value, thesis = _number(claim, got), float(claim["thesis_value"])
    return {"abs": lambda: abs(value - thesis) <= tol,
            "rel": lambda: abs(value - thesis) <= tol * abs(thesis),
            ">=": lambda: value >= thesis,
            "<=": lambda: value <= thesis}[kind]()


def _count(cid, scan, key):
    pair = scan.get(key)
    if not (isinstance(pair, list) and len(pair) == 2 and all(isinstance(v, int) and not isinstance(v, bool)
                                                                for v in pair) and 0 <= pair[0] <= pair[1] >= 1):
        raise ValueError(f"claim {cid!r}: scan[{key!r}] must be [holding, total] (integers, total >= 1), got {pair!r}")
    return pair


def check_scan(cid, scan):
    """Validate the scan of a ``computed`` claim (CLAIMS.md rule 2) and return it.

    ``table``: the figure or table of the notebook that shows the scan; ``seeds``: ``[holding, total]``,
    in how many of the seeds the statement holds at the chosen set-up (fewer than ``MIN_SEEDS`` seeds,
    as in a quick run, can never give "reproduced"), or None for an experiment with no random draw; ``settings``: ``[holding, total]``, in how many cells
    of the scan over the unstated settings it holds (for at least 9 of 10 seeds where seeded);
    ``flips``: where it flips (empty when it does not)."""
    if not isinstance(scan, dict):
        raise ValueError(f"claim {cid!r}: a computed claim needs its scan over what the thesis leaves open "
                         "(CLAIMS.md rule 2): {'table', 'seeds', 'settings', 'flips'}")
    unknown = set(scan) - {"table", "seeds", "settings", "flips"}
    if unknown or not str(scan.get("table", "")).strip():
        raise ValueError(f"claim {cid!r}: scan needs 'table' (the notebook's scan figure or table), 'seeds', "
                         f"'settings' and 'flips', got {sorted(scan)}")
    if scan.get("seeds") is not None:
        _count(cid, scan, "seeds")
    _count(cid, scan, "settings")
    if not isinstance(scan.get("flips", ""), str):
        raise ValueError(f"claim {cid!r}: scan['flips'] must be a sentence")
    return scan


def _robust(claim, ok, scan):
    """Reproduced / undetermined / differs for a computed claim from its rule and its scan."""
    scan = check_scan(claim["id"], scan)
    seeds, settings = scan.get("seeds"), scan["settings"]
    robust_seeds = seeds is None or (seeds[1] >= MIN_SEEDS and seeds[0] >= ROBUST_SEEDS * seeds[1])
    if ok and robust_seeds and settings[0] == settings[1]:
        return "reproduced"
    if not ok and (seeds is None or seeds[0] == 0) and settings[0] == 0:
        return "differs"
    return "undetermined"


def verdict(claim, got, scan=None):
    """Verdict for one claim row given our value (``None`` if no notebook reported it) and, for a
    ``computed`` claim, its scan (:func:`check_scan`)."""
    _parse_rule(claim)
    basis = claim["basis"]
    if basis == "original-data":
        return "not reproducible without the original data"
    if got is None:
        return "pending"
    if basis == "undetermined":
        if not (isinstance(got, list) and len(got) == 2 and all(isinstance(v, (int, float)) for v in got)
                and got[0] <= got[1]):
            raise ValueError(f"claim {claim['id']!r}: an undetermined claim needs a range [low, high], got {got!r}")
        return "undetermined"
    ok = _holds(claim, got)
    if basis == "computed":
        return _robust(claim, ok, scan)
    if basis == "construction" and not ok:
        raise ValueError(f"claim {claim['id']!r} holds by construction, but its check failed ({got!r}): "
                         "a bug of ours, not a finding about the thesis")
    return _PASS[basis] if ok else "differs"


def rule_problems(claim):
    """Why the claim's comparison rule could not fail, as far as the table shows:
    a tolerance as wide as the thesis value itself (``abs``) or 100% (``rel``), an infinite bound,
    ``>=`` a non-positive number (any count, distance, time or probability passes), ``<=`` 1 or
    more on a probability or share. Returns a list of sentences, empty when none applies."""
    kind, tol = _parse_rule(claim)
    if kind not in ("abs", "rel", ">=", "<="):
        return []
    try:
        thesis = float(claim["thesis_value"])
    except ValueError:
        return [f"rule {claim['compare']!r} needs a numeric thesis value, got {claim['thesis_value']!r}"]
    if not math.isfinite(thesis):
        return [f"the bound {claim['thesis_value']} is infinite: any value satisfies it"]
    problems = []
    if kind == "abs" and thesis != 0 and tol >= abs(thesis):
        problems.append(f"tolerance abs:{tol:g} is as wide as the thesis value {thesis:g} itself")
    if kind == "rel" and tol >= 1:
        problems.append(f"tolerance rel:{tol:g} accepts anything from 0 to {1 + tol:g} times the thesis value")
    if kind == ">=" and thesis <= 0:
        problems.append(f"'>= {thesis:g}' holds for any non-negative quantity; compute the strict comparison "
                        "and report it with rule 'true' if the quantity can be negative")
    if kind == "<=" and thesis >= 1 and _SHARE.search(claim["statement"]):
        problems.append(f"'<= {thesis:g}' holds for any probability or share")
    return problems
