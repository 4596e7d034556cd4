"""A notebook's results file: non-finite values refused, every result names its computation, and each file
records its run."""

import json
import re

import pytest

import mutual.compendium.runs as runs
from mutual.compendium.results import write_results

from helpers.claims import entry


def test_non_finite_results_are_refused(claims_file):
    with pytest.raises(ValueError, match="not finite"):
        write_results("09_demo", {"c9-abs": entry(float("nan"))})


@pytest.mark.parametrize("bad, message", [
    ({"value": 0.3, "computed_by": "mutual.study.stats.rm_anova"}, "claim 'c9-abs': the entry needs 'note'"),
    ({"value": 0.3, "note": "n = 50"}, "claim 'c9-abs': the entry needs 'computed_by'"),
    ({"value": 0.3, "note": " ", "computed_by": "mutual.study.stats.rm_anova"}, "needs 'note'"),
    (entry(0.3, by="numpy.mean"), "must name a library function of mutual"),
    (entry(0.3, by="mutual.compendium.results.write_results"), "not the compendium's machinery"),
    (entry(0.3, by="mutual.study.stats.no_such_function"), "mutual.study.stats has no no_such_function"),
    (entry(0.3, by="mutual.study.no_such_module.f"), "mutual.study has no no_such_module.f"),
    (entry(0.3, by="mutual.__version__"), "is not a function or class"),
    (0.3, "the entry must be a dict"),
])
def test_every_result_names_its_computation(claims_file, bad, message):
    with pytest.raises(ValueError, match=re.escape(message)) as err:
        write_results("09_demo", {"c9-abs": bad})
    assert "notebook 09_demo" in str(err.value)


def test_results_record_their_run(claims_file, monkeypatch):
    doc = json.loads(write_results("09_demo", {"c9-abs": entry(0.3)}).read_text())
    assert doc["run"]["mode"] == "full" and doc["run"]["parameters"] == {}
    assert doc["run"]["code_sha256"] == runs.code_sha256(claims_file.parent / "09_demo.ipynb")
    monkeypatch.setenv(runs.ENV_MODE, "quick")
    monkeypatch.setenv(runs.ENV_PARAMETERS, '{"quick": true}')
    doc = json.loads(write_results("09_demo", {"c9-abs": entry(0.3)}).read_text())
    assert doc["run"]["mode"] == "quick" and doc["run"]["parameters"] == {"quick": True}
    with pytest.raises(ValueError, match="name the results after the notebook's file"):
        write_results("09_other", {"c9-abs": entry(0.3)})
