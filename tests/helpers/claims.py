"""A synthetic claims table, settings and notebook for the compendium's tests (claims ``c9-*`` of a
chapter 9 that does not exist, so no test reads the real report)."""

import nbformat
import pandas as pd


SYNTHETIC_CLAIMS = pd.DataFrame([
    {"id": "c9-abs", "chapter": "9", "section": "9.1", "lines": "10", "statement": "x is 0.29", "thesis_value": "0.29",
     "compare": "abs:0.02", "basis": "computed", "figure": "fig_9_1"},
    {"id": "c9-ge", "chapter": "9", "section": "9.1", "lines": "11", "statement": "over 97%", "thesis_value": "0.97",
     "compare": ">=", "basis": "computed", "figure": ""},
    {"id": "c9-true", "chapter": "9", "section": "9.2", "lines": "12", "statement": "Lemma 9.2.1 holds",
     "thesis_value": "true", "compare": "true", "basis": "independent", "figure": ""},
    {"id": "c9-count", "chapter": "9", "section": "9.2", "lines": "13", "statement": "the counter gives T|X|^2",
     "thesis_value": "true", "compare": "true", "basis": "construction", "figure": ""},
    {"id": "c9-human", "chapter": "9", "section": "9.3", "lines": "14", "statement": "F(2, 20) = 8.72",
     "thesis_value": "8.72", "compare": "none", "basis": "original-data", "figure": ""},
    {"id": "c9-pending", "chapter": "9", "section": "9.3", "lines": "15", "statement": "later", "thesis_value": "1",
     "compare": "rel:0.1", "basis": "computed", "figure": ""},
    {"id": "c9-p-from-f", "chapter": "9", "section": "9.3", "lines": "16", "statement": "p = 0.002",
     "thesis_value": "0.002", "compare": "abs:0.0005", "basis": "thesis-numbers", "figure": ""},
    {"id": "c9-open", "chapter": "9", "section": "9.4", "lines": "17", "statement": "three times longer",
     "thesis_value": "3", "compare": "range", "basis": "undetermined", "figure": ""},
])


SYNTHETIC_SETTINGS = pd.DataFrame([{"id": "s9-n", "chapter": "9", "section": "9.1", "lines": "9", "setting": "demonstrations",
                          "value": "100", "used_in": "09_demo"}])


def scan(seeds=(10, 10), settings=(4, 4), flips=""):
    return {"table": "table_9_scan", "seeds": None if seeds is None else list(seeds), "settings": list(settings),
            "flips": flips}


def entry(value, note="n = 50", by="mutual.study.stats.rm_anova", **more):
    return {"value": value, "note": note, "computed_by": by, **more}


def notebook_file(tmp_path, *sources, tagged=True, name="99_demo"):
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "mutual", "display_name": "Python (mutual)", "language": "python"}
    nb.cells = [nbformat.v4.new_code_cell(s) for s in sources]
    if tagged:
        nb.cells[0].metadata["tags"] = ["parameters"]
    path = tmp_path / f"{name}.ipynb"
    nbformat.write(nb, path)
    return path
