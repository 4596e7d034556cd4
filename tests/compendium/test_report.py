"""The reproduction report: every claim with its verdict, unknown claim ids refused, extensions apart from the
verdicts, and the README's verdict counts equal to the report's."""

import json

import pytest

from mutual.compendium.claims import VERDICTS
from mutual.compendium.paths import FIGURES, ROOT
from mutual.compendium.report import README_BEGIN, README_END, build_report, summary_counts
from mutual.compendium.results import write_results

from helpers.claims import SYNTHETIC_CLAIMS, entry, scan


def test_report_lists_every_claim_with_its_verdict(claims_file):
    write_results("09_demo", {"c9-abs": entry(0.3, scan=scan()), "c9-ge": entry(0.99, scan=scan(None, (1, 1))),
                              "c9-true": entry(True), "c9-count": entry(True),
                              "c9-human": entry(4.0, simulated=True), "c9-p-from-f": entry(0.0021),
                              "c9-open": entry([1.5, 4.0])})
    text = build_report().read_text()
    rows = {line.split(" | ")[0].strip("| "): line for line in text.splitlines() if line.startswith("| c9-")}
    assert set(rows) == set(SYNTHETIC_CLAIMS["id"])
    assert "| reproduced |" in rows["c9-abs"] and "| pending |" in rows["c9-pending"]
    assert "| verified |" in rows["c9-true"] and "10/10 seeds; 4/4 settings (`table_9_scan`)" in rows["c9-abs"]
    assert "0.99 (n = 50; mutual.study.stats.rm_anova)" in rows["c9-ge"]
    own = text.split("## Holds by construction", 1)[1].split("## Settings", 1)[0]
    assert "c9-count" in own and "c9-count" not in text.split("## Holds by construction", 1)[0].split("Summary")[1]
    assert "| s9-n | 9.1 | 9 | demonstrations | 100 | 09_demo |" in text.split("## Settings the thesis fixes")[1]


def test_unknown_claim_id_is_an_error(claims_file, tmp_path):
    with pytest.raises(ValueError, match="c9-nope"):
        write_results("09_demo", {"c9-nope": entry(1.0)})
    path = write_results("09_demo", {"c9-abs": entry(0.3)})
    doc = json.loads(path.read_text())
    doc["claims"]["c9-nope"] = doc["claims"].pop("c9-abs")
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="unknown claim id 'c9-nope'"):
        build_report()


def test_extensions_are_reported_apart_from_the_verdicts(claims_file):
    from mutual.compendium.results import write_extensions
    write_results("09_demo", {"c9-abs": entry(0.3, scan=scan())})
    write_extensions("09_demo", {"power-n80": {"statement": "N for 80% power", "value": 14,
                                               "computed_by": "mutual.study.stats.rm_anova"},
                                 "cited-claim": {"statement": "[67]: a claim", "value": "9 of 10", "verdict": "undetermined",
                                                 "computed_by": "mutual.study.stats.rm_anova"}})
    text = build_report().read_text()
    summary, extensions = text.split("## Extensions beyond the thesis")
    assert "1 reproduced" in summary and "N for 80% power | 14 |  | yes | mutual.study.stats.rm_anova" in extensions
    assert "[67]: a claim | 9 of 10 | undetermined | yes |" in extensions and "1 undetermined" not in summary
    with pytest.raises(ValueError, match="computed_by"):
        write_extensions("09_demo", {"x": {"statement": "s", "value": 1}})
    with pytest.raises(ValueError, match="verdict 'fine'"):
        write_extensions("09_demo", {"x": {"statement": "s", "value": 1, "verdict": "fine",
                                           "computed_by": "mutual.study.stats.rm_anova"}})


def test_readme_states_the_reports_verdict_counts():
    readme = (ROOT / "README.md").read_text()
    assert README_BEGIN in readme and README_END in readme, "README.md: the verdict-count markers are missing"
    stated = readme.split(README_BEGIN, 1)[1].split(README_END, 1)[0]
    assert all(f" {v}" in stated for v in VERDICTS), f"README.md must state every verdict category: {stated.strip()!r}"
    report = (FIGURES / "REPRODUCTION.md").read_text()
    assert summary_counts(stated) == summary_counts(report), (
        f"README.md states {stated.strip()!r} but figures/REPRODUCTION.md says "
        f"{next(ln for ln in report.splitlines() if ln.startswith('Summary: '))!r}: run `make figures`")
