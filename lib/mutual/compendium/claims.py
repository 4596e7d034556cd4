"""The thesis's numeric and checkable claims (``data/paper_claims.csv``) and the
rules that turn a computed value into a verdict a reader can trust.

Columns: ``id`` (``c<chapter>-<slug>``), ``chapter``, ``section``, ``statement``,
``thesis_value``, ``compare``, ``basis`` and ``figure``.

``basis`` says what our value is, and so which verdicts it can earn:

* ``computed`` -- our code computed it independently, with the thesis's method and set-up:
  **reproduced** when the rule holds, else **differs**;
* ``thesis-numbers`` -- re-derived from numbers the thesis reports (Table 5.1 arithmetic,
  p-values from reported F statistics): **consistent** when the rule holds, else **differs**;
* ``undetermined`` -- the thesis does not give what the number depends on; the value is the
  range ``[low, high]`` over the plausible choices: **undetermined**;
* ``original-data`` -- needs the thesis's human data: **not reproducible without the original
  data**; a value computed on simulated data may be shown beside it.

``compare`` is the rule: ``abs:TOL`` / ``rel:TOL`` (numeric, |got - thesis| <= TOL, or
<= TOL * |thesis|), ``>=`` / ``<=`` (a bound on got), ``true`` (a check that reports True or
False), ``range`` (undetermined rows) or ``none`` (original-data rows).
"""

import math
import re

import pandas as pd

from . import paths

COLUMNS = ["id", "chapter", "section", "statement", "thesis_value", "compare", "basis", "figure"]
BASES = ("computed", "thesis-numbers", "undetermined", "original-data")
VERDICTS = ("reproduced", "consistent", "differs", "undetermined", "not reproducible without the original data",
            "pending")
_SHARE = re.compile(r"\b(p|p-value|probability|probabilities|rate|fraction|share|proportion)\b|%", re.I)
_RULES = {"computed": ("abs", "rel", ">=", "<=", "true"), "thesis-numbers": ("abs", "rel", ">=", "<=", "true"),
          "undetermined": ("range",), "original-data": ("none",)}


def load_claims(path=None):
    """Read and validate the claims table (default ``data/paper_claims.csv``)."""
    path = path or paths.CLAIMS
    df = pd.read_csv(path, dtype=str, keep_default_na=False)
    missing = [c for c in COLUMNS if c not in df.columns]
    if missing:
        raise ValueError(f"{path}: missing columns {missing}")
    dup = df["id"][df["id"].duplicated()].tolist()
    if dup:
        raise ValueError(f"{path}: duplicate claim ids {dup}")
    for claim in df.to_dict("records"):
        _parse_rule(claim)
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


def verdict(claim, got):
    """Verdict for one claim row given our value (``None`` if no notebook reported it)."""
    kind, tol = _parse_rule(claim)
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
    if kind == "true":
        if not isinstance(got, bool):
            raise ValueError(f"claim {claim['id']!r}: rule 'true' needs a boolean result, got {got!r}")
        ok = got
    else:
        value, thesis = _number(claim, got), float(claim["thesis_value"])
        ok = {"abs": lambda: abs(value - thesis) <= tol,
              "rel": lambda: abs(value - thesis) <= tol * abs(thesis),
              ">=": lambda: value >= thesis,
              "<=": lambda: value <= thesis}[kind]()
    if not ok:
        return "differs"
    return "reproduced" if basis == "computed" else "consistent"


def rule_problems(claim):
    """Why the claim's comparison rule could not fail, as far as the table shows (issue 10):
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
