"""An honest report (issue 10): no echo rows and no rule that cannot fail, as far as the machinery
can tell, read from the committed notebooks and the latest (this session's quick) results.

* every result of a ``computed``, ``thesis-numbers`` or ``undetermined`` claim names a ``mutual``
  function that the notebook calls (``computed_by``) and its computation (``note``);
* no such claim's value is a literal in the notebook (a constant, a name bound only to constants or
  to the parameters cell, arithmetic of those): parsed from the ``write_results`` calls with ast;
* no value merely echoes a setting the notebook typed in (it equals or nearly equals the thesis value
  and a constant the notebook set and fed into it, e.g. the simulator's parameter recovered by a fit;
  or, for a boolean, it compares a result with the setting that produced it);
* no comparison rule that cannot fail (tolerances as wide as the thesis value, bounds any value
  satisfies) and every rule fits its basis;
* the README states the report's verdict counts.
"""

import textwrap

import nbformat
import pytest
from mutual.compendium.audit import NotebookCode, Unresolved
from mutual.compendium.claims import VERDICTS, load_claims, load_settings, rule_problems, verdict
from mutual.compendium.paths import FIGURES, NOTEBOOKS, ROOT
from mutual.compendium.report import README_BEGIN, README_END, summary_counts
from mutual.compendium.results import resolve_computed_by

CLAIMS = load_claims()
BASIS = dict(zip(CLAIMS["id"], CLAIMS["basis"]))
CHECKED = ("computed", "independent", "thesis-numbers", "construction", "undetermined")  # original-data rows: simulated
CHAPTERS = sorted(p.stem for p in NOTEBOOKS.glob("[0-9][0-9]_*.ipynb") if not p.name.startswith("00_"))



def _report(stem, problems):
    assert not problems, f"notebook {stem}:\n  " + "\n  ".join(problems)


def test_every_claim_names_its_thesis_lines():
    assert not [cid for cid, lines in zip(CLAIMS["id"], CLAIMS["lines"]) if not lines.strip()], (
        "claims without their thesis lines (column 'lines' of data/paper_claims.csv)")


def test_settings_name_the_lines_that_fix_them():
    assert len(load_settings())


@pytest.mark.parametrize("claim", CLAIMS.to_dict("records"), ids=list(CLAIMS["id"]))
def test_every_rule_can_fail(claim):
    problems = rule_problems(claim)
    assert not problems, f"claim {claim['id']} (chapter {claim['chapter']}, rule {claim['compare']}): " + "; ".join(problems)


@pytest.mark.parametrize("stem", CHAPTERS)
def test_every_value_fits_its_claims_basis_and_rule(stem, executed_notebook):
    """A range for an undetermined claim, a boolean for rule 'true', a number for a numeric rule."""
    claims = CLAIMS.set_index("id")
    problems = []
    for cid, entry in sorted(executed_notebook(stem).items()):
        try:
            verdict(claims.loc[cid].to_dict() | {"id": cid}, entry["value"], entry.get("scan"))
        except ValueError as err:
            problems.append(str(err))
    _report(stem, problems)


@pytest.mark.parametrize("stem", CHAPTERS)
def test_reported_values_are_computed_not_typed_in(stem):
    code = NotebookCode(NOTEBOOKS / f"{stem}.ipynb")
    _report(stem, [f"{'claims ' if r.generated else 'claim '}{r.claim} ({BASIS.get(r.claim, 'generated ids')}, code "
                   f"cell {r.cell}): the value `{r.source[:70]}` is a literal typed into the notebook (a constant, a "
                   "parameter, or arithmetic of those), not a computed quantity" for r in code.reported()
                   if (r.generated or BASIS.get(r.claim) in CHECKED) and code.is_literal(r.value)])


@pytest.mark.parametrize("stem", CHAPTERS)
def test_results_name_the_function_the_notebook_calls(stem, executed_notebook):
    results = executed_notebook(stem)
    code = NotebookCode(NOTEBOOKS / f"{stem}.ipynb")
    problems = []
    for cid, entry in sorted(results.items()):
        if BASIS[cid] not in CHECKED:
            continue
        if not entry.get("note", "").strip():
            problems.append(f"claim {cid}: no note naming the computation")
        try:
            target = resolve_computed_by(entry.get("computed_by", ""))
        except ValueError as err:
            problems.append(f"claim {cid}: {err}")
            continue
        if not code.references(target):
            problems.append(f"claim {cid}: computed_by {entry['computed_by']} is never called in the notebook")
    _report(stem, problems)


@pytest.mark.parametrize("stem", CHAPTERS)
def test_no_value_echoes_a_setting(stem, executed_notebook):
    """A value that equals or nearly equals the thesis value and a constant the notebook set (and fed into
    the computation), or a boolean that compares a result with the setting that produced it, is the
    setting coming back: a settings-table entry, not a claim (CLAIMS.md)."""
    results = executed_notebook(stem)
    code = NotebookCode(NOTEBOOKS / f"{stem}.ipynb")
    claims = CLAIMS.set_index("id")
    reported = {r.claim: r for r in code.reported() if not r.generated}
    problems = []
    for cid, entry in sorted(results.items()):
        claim = claims.loc[cid]
        if claim["basis"] not in ("computed", "independent") or cid not in reported:
            continue
        why = code.echo(reported[cid], claim["thesis_value"], claim["compare"], entry["value"])
        if why:
            problems.append(f"claim {cid} ({claim['basis']}): {why} (an echo of an input)")
    _report(stem, problems)


def test_readme_states_the_reports_verdict_counts():
    readme = (ROOT / "README.md").read_text()
    assert README_BEGIN in readme and README_END in readme, "README.md: the verdict-count markers are missing"
    stated = readme.split(README_BEGIN, 1)[1].split(README_END, 1)[0]
    assert all(f" {v}" in stated for v in VERDICTS), f"README.md must state every verdict category: {stated.strip()!r}"
    report = (FIGURES / "REPRODUCTION.md").read_text()
    assert summary_counts(stated) == summary_counts(report), (
        f"README.md states {stated.strip()!r} but figures/REPRODUCTION.md says "
        f"{next(ln for ln in report.splitlines() if ln.startswith('Summary: '))!r}: run `make figures`")


# -- the checker itself, on a synthetic notebook --------------------------------------------------------

SYNTHETIC = [
    "quick = False\nn_recruits = 12\nw_max = 0.75",
    textwrap.dedent("""\
        import numpy as np
        from mutual.study import stats as st
        from mutual.study.stats import rm_anova
        import mutual.study.data
        const = 3
        derived = const * 2
        table = {}
        for k in range(3):
            table[k] = st.rm_anova(k)
        counts = []
        counts.append(rm_anova(1))
        fixed = []
        fixed.append(1)
        settings = {"goal": [2, -2]}
        total = 0
        total += 1
        summed = 0
        for k in st.rm_anova(3):
            summed += k
        looped = 0
        for j in range(3):
            looped += j
        pairs = [(name, st.rm_anova(name)) for name in ("a", "b")]
        data = mutual.study.data.read_table("x")
        claims = {
            "lit-true": {"value": True, "computed_by": "mutual.study.stats.rm_anova", "note": "n"},
            "lit-arith": {"value": 220 / 397},
            "lit-parameter": {"value": n_recruits},
            "lit-derived": {"value": derived},
            "lit-numpy": {"value": float(np.mean([1.0, 2.0]))},
            "lit-ifexp": {"value": 12 if quick else n_recruits},
            "lit-container": {"value": bool(len(fixed) == 1)},
            "lit-settings": {"value": settings["goal"][0] == 2},
            "lit-augmented": {"value": total},
            "lit-looped": {"value": looped},
            "computed-library": {"value": st.design_from_f_dofs(2, 20)},
            "computed-mutated": {"value": table[0] > 1},
            "computed-appended": {"value": counts[0]},
            "computed-loop": {"value": summed},
            "computed-bare": data,
        }
        proposed = {"computed-filtered": {"value": table[1]}, "unused": {"value": 1}}
        extra = {}
        extra["computed-item"] = {"value": st.rm_anova(2)}
        write_results("09_demo", {**claims, **{k: v for k, v in proposed.items() if k != "unused"}, **extra,
                                  **{f"computed-{name}": {"value": value} for name, value in pairs},
                                  **{f"lit-{kind}": {"value": typed} for kind, typed in [("x", 1.0), ("y", 2.0)]}})"""),
]


@pytest.fixture
def synthetic(tmp_path):
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(s) for s in SYNTHETIC]
    nb.cells[0].metadata["tags"] = ["parameters"]
    path = tmp_path / "09_demo.ipynb"
    nbformat.write(nb, path)
    return NotebookCode(path)


def test_the_checker_tells_literals_from_computed_values(synthetic):
    reported = {r.claim: r for r in synthetic.reported()}
    assert synthetic.parameters == {"quick", "n_recruits", "w_max"}
    literal = {c for c, r in reported.items() if synthetic.is_literal(r.value)}
    assert literal == {c for c in reported if c.startswith(("lit-", "f'lit-")) or c == "unused"}
    assert {c for c, r in reported.items() if r.generated} == {"f'computed-{name}'", "f'lit-{kind}'"}
    assert {"computed-filtered", "computed-item", "computed-bare"} <= set(reported)
    assert reported["lit-true"].computed_by is not None and reported["lit-arith"].computed_by is None
    assert synthetic.scalar_constants() == {"n_recruits": 12, "w_max": 0.75, "const": 3}


def test_the_checker_resolves_what_the_notebook_calls(synthetic):
    from mutual.study import data, stats

    assert synthetic.references(stats.rm_anova)  # through `st.` and through the `from` import
    assert synthetic.references(stats.design_from_f_dofs)
    assert synthetic.references(data.read_table)  # through the full dotted import
    assert not synthetic.references(stats.likert_vs_neutral)


ECHOES = [
    "quick = False\nexample_w_max = 0.75\nexample_mu = 0.5\nn_robots = 400",
    textwrap.dedent("""\
        from mutual.study import stats as st
        sup = st.rm_anova(example_w_max, example_mu)
        fit = st.rm_anova(sup, n_robots)
        recovered = fit.w_max == example_w_max
        close = abs(fit.mu - example_mu) < 0.05
        rate = st.rm_anova(sup)
        honest = rate <= 0.01
        write_results("09_demo", {
            "bool-echo": {"value": recovered}, "bool-close-echo": {"value": bool(close)},
            "bool-np-echo": {"value": bool(st.np.isclose(fit.mu, example_mu))},
            "bool-honest": {"value": honest}, "near-echo": {"value": fit.mu}, "far": {"value": rate},
            "unrelated": {"value": st.rm_anova(3)}})"""),
]


@pytest.mark.parametrize("claim, value, thesis, rule, echo", [
    ("bool-echo", True, "true", "true", True), ("bool-close-echo", True, "true", "true", True),
    ("bool-np-echo", False, "true", "true", True), ("bool-honest", True, "true", "true", False),
    ("near-echo", 0.503, "0.5", "abs:0.05", True), ("near-echo", 0.6, "0.5", "abs:0.05", False),
    ("near-echo", 0.5, "0.5", ">=", True), ("far", 0.56, "0.5", "abs:0.05", False), ("far", 0.53, "0.5", "abs:0.05", True),
    ("unrelated", 0.4975, "0.5", "abs:0.075", False), ("unrelated", 0.5, "0.5", "abs:0.075", True),
    ("near-echo", 0.75, "0.29", "abs:0.05", False),
])
def test_the_checker_sees_echoes(tmp_path, claim, value, thesis, rule, echo):
    """Booleans comparing a result with the setting that made it, and values that only nearly equal a
    typed constant that fed them, are echoes; a value that merely sits near the thesis value is not."""
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(s) for s in ECHOES]
    nb.cells[0].metadata["tags"] = ["parameters"]
    nbformat.write(nb, tmp_path / "09_demo.ipynb")
    code = NotebookCode(tmp_path / "09_demo.ipynb")
    reported = {r.claim: r for r in code.reported()}
    assert bool(code.echo(reported[claim], thesis, rule, value)) is echo


def test_the_checker_refuses_claims_it_cannot_read(tmp_path):
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell("quick = False"), nbformat.v4.new_code_cell(
        "claims = make_claims()\nwrite_results('09_demo', claims)")]
    nbformat.write(nb, tmp_path / "09_demo.ipynb")
    with pytest.raises(Unresolved, match=r"code cell 2: cannot read the claims from 'make_claims\(\)'"):
        NotebookCode(tmp_path / "09_demo.ipynb").reported()


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
