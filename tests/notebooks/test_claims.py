"""An honest report, read from the committed notebooks and this session's quick results: every value fits its
claim's basis and rule, is computed by a named ``mutual`` function the notebook calls (never a literal typed
into the notebook), and never echoes a setting."""

import pytest

from mutual.compendium.audit import NotebookCode
from mutual.compendium.claims import load_claims, verdict
from mutual.compendium.paths import NOTEBOOKS
from mutual.compendium.results import resolve_computed_by


CLAIMS = load_claims()
BASIS = dict(zip(CLAIMS["id"], CLAIMS["basis"]))
CHECKED = ("computed", "independent", "thesis-numbers", "construction", "undetermined")  # original-data rows: simulated
CHAPTERS = sorted(p.stem for p in NOTEBOOKS.glob("[0-9][0-9]_*.ipynb") if not p.name.startswith("00_"))


def _report(stem, problems):
    assert not problems, f"notebook {stem}:\n  " + "\n  ".join(problems)


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
        for name, part in [(cid, entry)] + ([(f"{cid} (the simulated value beside it)", entry["beside"])]
                                            if "beside" in entry else []):
            if not part.get("note", "").strip():
                problems.append(f"claim {name}: no note naming the computation")
            try:
                target = resolve_computed_by(part.get("computed_by", ""))
            except ValueError as err:
                problems.append(f"claim {name}: {err}")
                continue
            if not code.references(target):
                problems.append(f"claim {name}: computed_by {part['computed_by']} is never called in the notebook")
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
