"""The compendium's machinery: paths, atomic writes, deterministic figures,
results files, the reproduction report and the notebook runner."""

import hashlib
import json
import re
import subprocess
import sys
import textwrap

import nbformat
import pandas as pd
import pytest

import mutual.compendium.paths as paths
import mutual.compendium.runs as runs
from mutual.atomic import atomic_path
from mutual.compendium.claims import verdict
from mutual.compendium.figures import save_animation, save_table, savefig
from mutual.compendium.notebooks import NotebookError, declared_parameters, execute
from mutual.compendium.report import build_report
from mutual.compendium.results import write_results


def test_root_is_independent_of_working_directory(tmp_path):
    out = subprocess.run([sys.executable, "-c", "import mutual.compendium.paths as p; print(p.ROOT)"],
                         cwd=tmp_path, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == str(paths.ROOT)
    assert (paths.ROOT / "pyproject.toml").exists()


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "fig.png"
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert list(tmp_path.iterdir()) == []


FIGURE_SCRIPT = textwrap.dedent("""
    import numpy as np, matplotlib.pyplot as plt
    from mutual.compendium.figures import use_style, savefig
    use_style()
    fig, ax = plt.subplots()
    ax.plot(np.linspace(0, 1, 50) ** 2, label="a")
    ax.contourf(np.random.default_rng(0).random((5, 5)))
    ax.legend()
    savefig(fig, "fig_9_1")
    from matplotlib.animation import FuncAnimation
    from mutual.compendium.figures import save_animation
    line, = ax.plot([], [])
    save_animation(FuncAnimation(fig, lambda k: line.set_data(np.arange(k), np.arange(k)), frames=8), "anim_9_1")
""")


def _digests(folder):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


def test_figures_are_byte_identical_across_runs(tmp_path):
    digests = []
    for run in ("a", "b"):
        out = tmp_path / run
        env = {**__import__("os").environ, "MUTUAL_OUTPUT_DIR": str(out), "MPLBACKEND": "Agg"}
        env.pop("SOURCE_DATE_EPOCH", None)
        subprocess.run([sys.executable, "-c", FIGURE_SCRIPT], env=env, check=True)
        digests.append(_digests(out))
    assert set(digests[0]) == {"fig_9_1.pdf", "fig_9_1.png", "anim_9_1.gif"}
    assert digests[0] == digests[1]


def test_figure_and_table_names_are_checked(tmp_path, monkeypatch):
    monkeypatch.setenv("MUTUAL_OUTPUT_DIR", str(tmp_path))
    with pytest.raises(ValueError, match="fig_3_1"):
        savefig(None, "figure3")
    with pytest.raises(ValueError, match="table"):
        save_table(pd.DataFrame({"a": [1]}), "fig_5_1")
    save_table(pd.DataFrame({"set": ["Standard"], "fp": [1.25]}), "table_9_1")
    with pytest.raises(ValueError, match="anim"):
        save_animation(None, "fig_9_1")
    assert (tmp_path / "table_9_1.md").read_text().splitlines()[0] == "| set | fp |"


CLAIMS = pd.DataFrame([
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
SETTINGS = pd.DataFrame([{"id": "s9-n", "chapter": "9", "section": "9.1", "lines": "9", "setting": "demonstrations",
                          "value": "100", "used_in": "09_demo"}])


def scan(seeds=(10, 10), settings=(4, 4), flips=""):
    return {"table": "table_9_scan", "seeds": None if seeds is None else list(seeds), "settings": list(settings),
            "flips": flips}


@pytest.fixture
def claims_file(tmp_path, monkeypatch):
    """The claims above, an output folder in ``tmp_path`` and a run of the notebook ``09_demo`` (as the
    runner would tell its kernel), so that ``write_results("09_demo", ...)`` works in-process."""
    path = tmp_path / "claims.csv"
    CLAIMS.to_csv(path, index=False)
    monkeypatch.setattr(paths, "CLAIMS", path)
    SETTINGS.to_csv(tmp_path / "settings.csv", index=False)
    monkeypatch.setattr(paths, "SETTINGS", tmp_path / "settings.csv")
    monkeypatch.setenv("MUTUAL_OUTPUT_DIR", str(tmp_path / "figures"))
    notebook = _notebook(tmp_path, "quick = False", "x = 1", name="09_demo")
    for key, value in runs.kernel_env(notebook, {}).items():
        monkeypatch.setenv(key, value)
    return path


def entry(value, note="n = 50", by="mutual.study.stats.rm_anova", **more):
    return {"value": value, "note": note, "computed_by": by, **more}


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
    row = CLAIMS.set_index("id").loc[cid].to_dict() | {"id": cid}
    assert verdict(row, got, sweep) == expected


@pytest.mark.parametrize("sweep, message", [
    (None, "needs its scan"), (scan(settings=(5, 4)), "holding, total"), (scan((1, 0)), "holding, total"),
    ({"seeds": [10, 10], "settings": [1, 1]}, "needs 'table'"), (scan() | {"seed": 3}, "needs 'table'"),
])
def test_a_computed_claim_needs_a_valid_scan(sweep, message):
    row = CLAIMS.set_index("id").loc["c9-abs"].to_dict() | {"id": "c9-abs"}
    with pytest.raises(ValueError, match=message):
        verdict(row, 0.3, sweep)


def test_a_failing_check_of_our_own_code_stops_the_report():
    row = CLAIMS.set_index("id").loc["c9-count"].to_dict() | {"id": "c9-count"}
    with pytest.raises(ValueError, match="a bug of ours"):
        verdict(row, False)


def test_report_lists_every_claim_with_its_verdict(claims_file):
    write_results("09_demo", {"c9-abs": entry(0.3, scan=scan()), "c9-ge": entry(0.99, scan=scan(None, (1, 1))),
                              "c9-true": entry(True), "c9-count": entry(True),
                              "c9-human": entry(4.0, simulated=True), "c9-p-from-f": entry(0.0021),
                              "c9-open": entry([1.5, 4.0])})
    text = build_report().read_text()
    rows = {line.split(" | ")[0].strip("| "): line for line in text.splitlines() if line.startswith("| c9-")}
    assert set(rows) == set(CLAIMS["id"])
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


def _notebook(tmp_path, *sources, tagged=True, name="99_demo"):
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "mutual", "display_name": "Python (mutual)", "language": "python"}
    nb.cells = [nbformat.v4.new_code_cell(s) for s in sources]
    if tagged:
        nb.cells[0].metadata["tags"] = ["parameters"]
    path = tmp_path / f"{name}.ipynb"
    nbformat.write(nb, path)
    return path


def test_runner_names_the_failing_cell(tmp_path):
    path = _notebook(tmp_path, "quick = False", "x = 1", "raise RuntimeError('boom')")
    with pytest.raises(NotebookError, match=r"99_demo.ipynb failed in code cell 3 \(\"raise RuntimeError\(.boom.\)\"\): RuntimeError: boom"):
        execute(path, {"quick": True})


def test_runner_requires_declared_parameters(tmp_path):
    with pytest.raises(ValueError, match="exactly one cell tagged 'parameters'"):
        declared_parameters(_notebook(tmp_path, "quick = False", tagged=False))
    with pytest.raises(ValueError, match="must declare 'quick'"):
        declared_parameters(_notebook(tmp_path, "seed = 0"))
    with pytest.raises(ValueError, match="no parameter named 'n_demos'"):
        execute(_notebook(tmp_path, "quick = False"), {"n_demos": 3})


def test_make_figures_runner_exits_non_zero_naming_the_notebook(tmp_path):
    path = _notebook(tmp_path, "quick = False", "1 / 0")
    out = subprocess.run([sys.executable, "-m", "mutual.compendium.notebooks", "--quick", str(path)],
                         capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode != 0
    assert "99_demo.ipynb failed in code cell 2 ('1 / 0')" in out.stderr and "ZeroDivisionError" in out.stderr
    assert "Traceback" not in out.stderr and len(out.stderr.strip().splitlines()) == 1


def test_rules_must_fit_their_basis():
    row = CLAIMS.set_index("id").loc["c9-open"].to_dict() | {"id": "c9-open"}
    with pytest.raises(ValueError, match=r"range \[low, high\]"):
        verdict(row, 3.0)
    with pytest.raises(ValueError, match="does not fit basis"):
        verdict(row | {"compare": "abs:0.1"}, 3.0)
    with pytest.raises(ValueError, match="basis 'echo'"):
        verdict(row | {"basis": "echo"}, 3.0)


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


def test_batch_runs_print_no_progress_bars(tmp_path):
    """TQDM_DISABLE=1 plus the runner's kernel start-up line: even a bar asked for explicitly stays silent."""
    path = _notebook(tmp_path, "quick = False", "import os\nfrom tqdm import tqdm\nfrom tqdm.auto import tqdm as auto\n"
                     "total = sum(tqdm(range(5), disable=False, desc='loud')) + sum(auto(range(5)))\n"
                     "print(total, os.environ['TQDM_DISABLE'])")
    nb = execute(path, {"quick": True})
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    assert [o.get("text") for o in outputs] == ["20 1\n"], outputs
