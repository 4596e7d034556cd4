"""The thesis's numeric and checkable claims (``data/paper_claims.csv``) and the
rules that compare a reproduced value with them.

Columns: ``id`` (``c<chapter>-<slug>``), ``chapter``, ``section``, ``statement``,
``thesis_value``, ``compare`` and ``figure``. ``compare`` is one of

* ``abs:TOL`` / ``rel:TOL`` -- numeric, reproduced when |got - thesis| <= TOL
  (absolute) or <= TOL * |thesis| (relative);
* ``>=`` / ``<=`` -- numeric bound, reproduced when got >= (<=) the thesis value;
* ``true`` -- a checkable statement, reproduced when the notebook reports True;
* ``original-data`` -- needs the thesis's human data: never "reproduced", the
  simulated value is shown beside it for reference.
"""

import pandas as pd

from . import paths

COLUMNS = ["id", "chapter", "section", "statement", "thesis_value", "compare", "figure"]
VERDICTS = ("reproduced", "differs", "not reproducible without the original data", "pending")


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
    for cid, rule in zip(df["id"], df["compare"]):
        _parse_rule(rule, cid)
    return df


def _parse_rule(rule, cid):
    kind, _, tol = rule.partition(":")
    if kind in ("abs", "rel"):
        try:
            return kind, float(tol)
        except ValueError:
            raise ValueError(f"claim {cid!r}: compare rule {rule!r} needs a numeric tolerance") from None
    if rule in (">=", "<=", "true", "original-data"):
        return rule, None
    raise ValueError(f"claim {cid!r}: unknown compare rule {rule!r}")


def verdict(claim, got):
    """Verdict for one claim row given the reproduced value (``None`` if pending)."""
    kind, tol = _parse_rule(claim["compare"], claim["id"])
    if kind == "original-data":
        return VERDICTS[2]
    if got is None:
        return VERDICTS[3]
    if kind == "true":
        if not isinstance(got, bool):
            raise ValueError(f"claim {claim['id']!r}: rule 'true' needs a boolean result, got {got!r}")
        return VERDICTS[0] if got else VERDICTS[1]
    if isinstance(got, bool) or not isinstance(got, (int, float)):
        raise ValueError(f"claim {claim['id']!r}: rule {claim['compare']!r} needs a number, got {got!r}")
    thesis = float(claim["thesis_value"])
    ok = {"abs": lambda: abs(got - thesis) <= tol,
          "rel": lambda: abs(got - thesis) <= tol * abs(thesis),
          ">=": lambda: got >= thesis,
          "<=": lambda: got <= thesis}[kind]()
    return VERDICTS[0] if ok else VERDICTS[1]
