"""One number, one row: a row checked from the thesis's own numbers whose number itself needs the
study's data carries the SIMULATED study's value beside it (``write_results(..., {"beside": ...})``),
labelled in the report, and that value never decides the verdict."""

import json
import re

import pytest

import mutual.compendium.paths as paths
from mutual.compendium.report import build_report, report_table
from mutual.compendium.results import write_results

from helpers.claims import entry

BY = "mutual.study.published.f_p_value"
SIMULATED = {"value": 0.0002, "note": "SIMULATED study: rm_anova", "computed_by": "mutual.study.stats.rm_anova"}


@pytest.mark.parametrize("p, beside_p, verdict", [
    (0.0021, 0.0002, "consistent"), (0.0021, 0.5, "consistent"),  # the simulated value never decides
    (0.01, 0.0021, "differs"),                                      # the check from the thesis's numbers does
])
def test_the_value_beside_is_shown_and_never_decides(claims_file, p, beside_p, verdict):
    write_results("09_demo", {"c9-p-from-f": entry(p, note="upper tail of F(2, 20)", by=BY,
                                                   beside=SIMULATED | {"value": beside_p}),
                              "c9-human": entry(13.1, simulated=True)})
    row = report_table().set_index("id").loc["c9-p-from-f"]
    assert row["verdict"] == verdict
    assert row["reproduced"] == (f"{p:.4g} (upper tail of F(2, 20); {BY}); beside it, SIMULATED: {beside_p:.4g} "
                                 "(SIMULATED study: rm_anova; mutual.study.stats.rm_anova)")
    assert row["simulated inputs"] == "no; the value beside it: yes"
    text = build_report().read_text()
    assert "beside it, SIMULATED: " in next(line for line in text.splitlines() if line.startswith("| c9-p-from-f |"))


def test_rows_without_a_value_beside_read_as_before(claims_file):
    write_results("09_demo", {"c9-p-from-f": entry(0.0021, note="upper tail of F(2, 20)", by=BY)})
    row = report_table().set_index("id").loc["c9-p-from-f"]
    assert row["reproduced"] == f"0.0021 (upper tail of F(2, 20); {BY})"
    assert row["simulated inputs"] == "no"
    stored = json.loads((paths.results_dir() / "09_demo.json").read_text())["claims"]["c9-p-from-f"]
    assert "beside" not in stored


@pytest.mark.parametrize("cid, beside, message", [
    ("c9-human", SIMULATED, "an original-data row's own value is the simulated one"),
    ("c9-p-from-f", {"value": 1.0, "note": "x"}, "'beside' must be a dict with exactly 'value', 'computed_by' and 'note'"),
    ("c9-p-from-f", SIMULATED | {"simulated": True}, "'beside' must be a dict with exactly"),
    ("c9-p-from-f", 0.0002, "'beside' must be a dict with exactly"),
    ("c9-p-from-f", SIMULATED | {"note": " "}, "claim 'c9-p-from-f (beside)': the entry needs 'note'"),
    ("c9-p-from-f", SIMULATED | {"computed_by": "numpy.mean"}, "must name a library function of mutual"),
    ("c9-p-from-f", SIMULATED | {"value": float("inf")}, "not finite"),
])
def test_a_bad_value_beside_is_refused(claims_file, cid, beside, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        write_results("09_demo", {cid: entry(0.0021, by=BY, beside=beside)})
