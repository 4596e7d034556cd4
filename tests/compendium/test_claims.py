"""The claims and their verdicts (shared/CLAIMS.md): every claim names its thesis lines, settings the lines
that fix them; verdicts follow the basis and the rule; a computed claim needs a valid scan; a failing
check of our own code stops the report; a rule that cannot fail is named."""

import pytest

from mutual.compendium.claims import load_claims, load_settings, rule_problems, verdict

from helpers.claims import SYNTHETIC_CLAIMS, scan


@pytest.mark.parametrize("cid, got, sweep, expected", [
    ("c9-abs", 0.30, scan(), "reproduced"), ("c9-abs", 0.35, scan((0, 10), (0, 4)), "differs"),
    ("c9-abs", 0.30, scan((8, 10)), "undetermined"), ("c9-abs", 0.30, scan(settings=(3, 4)), "undetermined"),
    ("c9-abs", 0.35, scan((0, 10), (1, 4)), "undetermined"), ("c9-abs", 0.30, scan((9, 10)), "reproduced"),
    ("c9-abs", 0.30, scan((2, 2)), "undetermined"),
    ("c9-ge", 0.98, scan(None, (1, 1)), "reproduced"), ("c9-ge", 0.90, scan(None, (0, 1)), "differs"),
    ("c9-true", True, None, "verified"), ("c9-true", False, None, "differs"),
    ("c9-count", True, None, "holds by construction"),
    ("c9-human", 3.1, None, "not reproducible without the original data"), ("c9-pending", None, None, "pending"),
    ("c9-p-from-f", 0.0021, None, "consistent"), ("c9-p-from-f", 0.01, None, "differs"),
    ("c9-open", [1.5, 4.0], None, "undetermined"),
])
def test_verdicts(cid, got, sweep, expected):
    row = SYNTHETIC_CLAIMS.set_index("id").loc[cid].to_dict() | {"id": cid}
    assert verdict(row, got, sweep) == expected


@pytest.mark.parametrize("sweep, message", [
    (None, "needs its scan"), (scan(settings=(5, 4)), "holding, total"), (scan((1, 0)), "holding, total"),
    ({"seeds": [10, 10], "settings": [1, 1]}, "needs 'table'"), (scan() | {"seed": 3}, "needs 'table'"),
])
def test_a_computed_claim_needs_a_valid_scan(sweep, message):
    row = SYNTHETIC_CLAIMS.set_index("id").loc["c9-abs"].to_dict() | {"id": "c9-abs"}
    with pytest.raises(ValueError, match=message):
        verdict(row, 0.3, sweep)


def test_a_failing_check_of_our_own_code_stops_the_report():
    row = SYNTHETIC_CLAIMS.set_index("id").loc["c9-count"].to_dict() | {"id": "c9-count"}
    with pytest.raises(ValueError, match="a bug of ours"):
        verdict(row, False)


def test_rules_must_fit_their_basis():
    row = SYNTHETIC_CLAIMS.set_index("id").loc["c9-open"].to_dict() | {"id": "c9-open"}
    with pytest.raises(ValueError, match=r"range \[low, high\]"):
        verdict(row, 3.0)
    with pytest.raises(ValueError, match="does not fit basis"):
        verdict(row | {"compare": "abs:0.1"}, 3.0)
    with pytest.raises(ValueError, match="basis 'echo'"):
        verdict(row | {"basis": "echo"}, 3.0)


CLAIMS = load_claims()


def test_every_claim_names_its_thesis_lines():
    assert not [cid for cid, lines in zip(CLAIMS["id"], CLAIMS["lines"]) if not lines.strip()], (
        "claims without their thesis lines (column 'lines' of data/paper_claims.csv)")


def test_settings_name_the_lines_that_fix_them():
    assert len(load_settings())


@pytest.mark.parametrize("claim", CLAIMS.to_dict("records"), ids=list(CLAIMS["id"]))
def test_every_rule_can_fail(claim):
    problems = rule_problems(claim)
    assert not problems, f"claim {claim['id']} (chapter {claim['chapter']}, rule {claim['compare']}): " + "; ".join(problems)


@pytest.mark.parametrize("thesis, rule, statement, phrase", [
    ("0.29", "abs:0.3", "F = 29%", "as wide as the thesis value"),
    ("3", "rel:1", "three times longer", "from 0 to 2 times"),
    ("0", ">=", "the gain is positive", "any non-negative quantity"),
    ("-1", ">=", "a correlation", "any non-negative quantity"),
    ("1", "<=", "p < 1", "any probability or share"),
    ("inf", "<=", "finite", "infinite"),
    ("three", "abs:0.1", "x", "needs a numeric thesis value"),
])
def test_rules_that_cannot_fail_are_named(thesis, rule, statement, phrase):
    claim = {"id": "c9-x", "chapter": "9", "statement": statement, "thesis_value": thesis, "compare": rule,
             "basis": "computed"}
    assert any(phrase in p for p in rule_problems(claim)), rule_problems(claim)


@pytest.mark.parametrize("thesis, rule, statement", [
    ("0.29", "abs:0.05", "F = 29%"), ("3", "rel:0.2", "three times"), ("0.97", ">=", "over 97%"),
    ("5", "<=", "by the fifth round"), ("0.05", "<=", "p < .05"), ("0", "abs:0", "no false positives"),
])
def test_rules_that_can_fail_pass(thesis, rule, statement):
    claim = {"id": "c9-x", "chapter": "9", "statement": statement, "thesis_value": thesis, "compare": rule,
             "basis": "computed"}
    assert rule_problems(claim) == []
