"""One number, one row: a row checked from the thesis's own numbers whose number itself needs the
study's data carries the SIMULATED study's value beside it (``write_results(..., {"beside": ...})``),
labelled in the report, and that value never decides the verdict."""

import json
import re

import nbformat
import pandas as pd
import pytest

import mutual.compendium.paths as paths
import mutual.compendium.runs as runs
from mutual.compendium.report import build_report, report_table
from mutual.compendium.results import write_results

CLAIMS = pd.DataFrame([
    {"id": "c9-p", "chapter": "9", "section": "9.3", "lines": "16",
     "statement": "p < 0.01 (F(2, 20) = 8.72; the F itself needs the study's data)", "thesis_value": "0.01",
     "compare": "<=", "basis": "thesis-numbers", "figure": ""},
    {"id": "c9-f", "chapter": "9", "section": "9.3", "lines": "16", "statement": "F(2, 20) = 8.72",
     "thesis_value": "8.72", "compare": "none", "basis": "original-data", "figure": ""},
])


@pytest.fixture
def claims_file(tmp_path, monkeypatch):
    """The claims above, an output folder in ``tmp_path`` and a run of the notebook ``09_demo``."""
    path = tmp_path / "claims.csv"
    CLAIMS.to_csv(path, index=False)
    monkeypatch.setattr(paths, "CLAIMS", path)
    monkeypatch.setenv("MUTUAL_OUTPUT_DIR", str(tmp_path / "figures"))
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell("quick = False")]
    nb.cells[0].metadata["tags"] = ["parameters"]
    nbformat.write(nb, tmp_path / "09_demo.ipynb")
    for key, value in runs.kernel_env(tmp_path / "09_demo.ipynb", {}).items():
        monkeypatch.setenv(key, value)
    return path


def entry(value, note="upper tail of F(2, 20)", by="mutual.study.published.f_p_value", **more):
    return {"value": value, "note": note, "computed_by": by, **more}


SIMULATED = {"value": 0.0002, "note": "SIMULATED study: rm_anova", "computed_by": "mutual.study.stats.rm_anova"}


@pytest.mark.parametrize("p, beside_p, verdict", [
    (0.0019, 0.0002, "consistent"), (0.0019, 0.5, "consistent"),  # the simulated value never decides
    (0.03, 0.0002, "differs"),                                      # the check from the thesis's numbers does
])
def test_the_value_beside_is_shown_and_never_decides(claims_file, p, beside_p, verdict):
    write_results("09_demo", {"c9-p": entry(p, beside=SIMULATED | {"value": beside_p}),
                              "c9-f": entry(13.1, simulated=True, by="mutual.study.stats.rm_anova")})
    row = report_table().set_index("id").loc["c9-p"]
    assert row["verdict"] == verdict
    assert row["reproduced"] == (f"{p:.4g} (upper tail of F(2, 20); mutual.study.published.f_p_value); beside it, "
                                 f"SIMULATED: {beside_p:.4g} (SIMULATED study: rm_anova; mutual.study.stats.rm_anova)")
    assert row["simulated inputs"] == "no; the value beside it: yes"
    text = build_report().read_text()
    assert "beside it, SIMULATED: " in next(line for line in text.splitlines() if line.startswith("| c9-p |"))


def test_rows_without_a_value_beside_read_as_before(claims_file):
    write_results("09_demo", {"c9-p": entry(0.0019)})
    row = report_table().set_index("id").loc["c9-p"]
    assert row["reproduced"] == "0.0019 (upper tail of F(2, 20); mutual.study.published.f_p_value)"
    assert row["simulated inputs"] == "no"
    stored = json.loads((paths.results_dir() / "09_demo.json").read_text())["claims"]["c9-p"]
    assert "beside" not in stored


@pytest.mark.parametrize("cid, beside, message", [
    ("c9-f", SIMULATED, "an original-data row's own value is the simulated one"),
    ("c9-p", {"value": 1.0, "note": "x"}, "'beside' must be a dict with exactly 'value', 'computed_by' and 'note'"),
    ("c9-p", SIMULATED | {"simulated": True}, "'beside' must be a dict with exactly"),
    ("c9-p", 0.0002, "'beside' must be a dict with exactly"),
    ("c9-p", SIMULATED | {"note": " "}, "claim 'c9-p (beside)': the entry needs 'note'"),
    ("c9-p", SIMULATED | {"computed_by": "numpy.mean"}, "must name a library function of mutual"),
    ("c9-p", SIMULATED | {"value": float("inf")}, "not finite"),
])
def test_a_bad_value_beside_is_refused(claims_file, cid, beside, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        write_results("09_demo", {cid: entry(0.0019, beside=beside)})
