"""`make book`'s preparation of the pages (book/build.py), without building the site: widgets made
static from the state nbclient saved, links pointed at the book's pages, executed copies checked
against the notebooks, and the site theme pinned."""

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("book_build", ROOT / "book" / "build.py")
build = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(build)

PNG = {"image/png": "iVBORw0KGgo=", "text/plain": "<Figure size 640x480 with 1 Axes>"}


def widget_notebook():
    """An executed notebook as nbclient writes it after `interact(view, alpha=FloatSlider(...))`."""
    def model(name, **state):
        return {"model_name": name, "model_module": "@jupyter-widgets/controls", "model_module_version": "2.0.0",
                "state": {"_model_name": name, **state}}

    state = {
        "box": model("VBoxModel", children=["IPY_MODEL_alpha", "IPY_MODEL_mode", "IPY_MODEL_out"]),
        "alpha": model("FloatSliderModel", description="alpha", value=0.5),
        "mode": model("DropdownModel", description="mode", index=1, _options_labels=["fast", "exact"]),
        "out": model("OutputModel", outputs=[{"output_type": "display_data", "data": PNG, "metadata": {}}]),
    }
    view = {"output_type": "display_data", "metadata": {},
            "data": {build.WIDGET_VIEW: {"model_id": "box", "version_major": 2, "version_minor": 0},
                     "text/plain": "interactive(children=(FloatSlider(value=0.5, ...)))"}}
    orphan = {"output_type": "display_data", "metadata": {},
              "data": {build.WIDGET_VIEW: {"model_id": "gone"}, "text/plain": "IntSlider(value=3)"}}
    return {"cells": [{"cell_type": "code", "source": "interact(...)", "metadata": {}, "outputs": [view, orphan]}],
            "metadata": {"widgets": {build.WIDGET_STATE: {"state": state, "version_major": 2, "version_minor": 0}}}}


def test_a_widget_view_becomes_its_controls_and_the_output_it_drew():
    nb = widget_notebook()
    assert build.static_widgets(nb) == 1
    outputs = nb["cells"][0]["outputs"]
    assert outputs[0]["output_type"] == "stream"
    assert "alpha = 0.5" in outputs[0]["text"] and "mode = exact" in outputs[0]["text"]
    assert outputs[1]["data"] == PNG                                  # the figure the view drew
    assert outputs[2]["data"] == {"text/plain": "IntSlider(value=3)"}  # no state saved: its text form
    assert "widgets" not in nb["metadata"]


def test_links_point_at_the_book_pages():
    known = dict(build.PAGES) | {"notebooks/04_user_study.ipynb": "notebooks/04_user_study.ipynb",
                                 "figures/anim_6_1.gif": "figures/anim_6_1.gif"}
    text = ("[prev](04_user_study.ipynb) [report](../figures/REPRODUCTION.md#summary) [data](../data/README.md) "
            "[web](https://example.org/x.md) [anchor](#explore) ![anim](../figures/anim_6_1.gif) "
            "![missing](../figures/none.png)")
    out = build.rewrite_links(text, "notebooks/05_legibility_lqr.ipynb", known)
    assert "[prev](04_user_study.ipynb)" in out
    assert "[report](../reproduction.md#summary)" in out
    assert "data" in out and "../data/README.md" not in out            # not in the book: text only
    assert "[web](https://example.org/x.md)" in out and "[anchor](#explore)" in out
    assert "![anim](../figures/anim_6_1.gif)" in out and "![missing](../figures/none.png)" in out
    readme = build.rewrite_links("see [the report](figures/REPRODUCTION.md) and [start](notebooks/04_user_study.ipynb)",
                                 "README.md", known)
    assert readme == "see [the report](reproduction.md) and [start](notebooks/04_user_study.ipynb)"


def test_the_landing_page_is_the_readme_without_comments():
    page = build.landing_page("# Title\n\nIntro.\n<!-- counts -->\nSummary: 1 reproduced\n<!-- /counts -->\n")
    assert page.startswith("# Title\n") and "How to read this book" in page
    assert "<!--" not in page and "Summary: 1 reproduced" in page


def write_notebook(path, cells):
    path.write_text(json.dumps({"cells": cells, "metadata": {}, "nbformat": 4, "nbformat_minor": 5}))


def cell(kind, source, outputs=None, tags=()):
    c = {"cell_type": kind, "source": source, "metadata": {"tags": list(tags)}}
    if kind == "code":
        c["outputs"] = outputs or []
    return c


def test_executed_copies_must_exist_be_current_and_have_run_through(tmp_path):
    notebooks, executed = tmp_path / "notebooks", tmp_path / "executed"
    notebooks.mkdir(), executed.mkdir()
    source = [cell("markdown", "# Title"), cell("code", "quick = False", tags=["parameters"]), cell("code", "x = 1")]
    write_notebook(notebooks / "01_a.ipynb", source)
    with pytest.raises(build.BookError, match="no executed copy of .*01_a.ipynb.*make figures"):
        build.executed_notebooks(executed, notebooks)
    injected = source[:2] + [cell("code", "quick = True", tags=["injected-parameters"])] + source[2:]
    write_notebook(executed / "01_a.ipynb", injected)
    assert [p.name for p, _ in build.executed_notebooks(executed, notebooks)] == ["01_a.ipynb"]
    write_notebook(notebooks / "01_a.ipynb", source[:2] + [cell("code", "x = 2")])
    with pytest.raises(build.BookError, match="older than .*01_a.ipynb"):
        build.executed_notebooks(executed, notebooks)
    failed = source[:2] + [cell("code", "x = 1", [{"output_type": "error", "ename": "ValueError", "evalue": "bad"}])]
    write_notebook(notebooks / "01_a.ipynb", source)
    write_notebook(executed / "01_a.ipynb", failed)
    with pytest.raises(build.BookError, match="ValueError: bad.*did not run through"):
        build.executed_notebooks(executed, notebooks)


def test_the_theme_is_rebuilt_when_its_source_changes(tmp_path):
    (tmp_path / "app").mkdir()
    (tmp_path / "app" / "root.tsx").write_text("a")
    first = build.theme_fingerprint(tmp_path)
    assert build.theme_fingerprint(tmp_path) == first
    (tmp_path / "app" / "root.tsx").write_text("b")
    assert build.theme_fingerprint(tmp_path) != first


def test_the_site_theme_is_pinned_and_loads_nothing_from_the_internet():
    theme = ROOT / "book" / "theme"
    package = json.loads((theme / "package.json").read_text())
    for section in ("dependencies", "devDependencies"):
        loose = {n: v for n, v in package[section].items() if not v[0].isdigit()}
        assert not loose, f"book/theme/package.json: {section} not pinned to one version: {loose}"
    lock = json.loads((theme / "package-lock.json").read_text())
    assert lock["packages"][""]["dependencies"] == package["dependencies"]
    unhashed = [k for k, v in lock["packages"].items() if k and not v.get("link") and "integrity" not in v]
    assert not unhashed, f"book/theme/package-lock.json: packages without an integrity hash: {unhashed[:5]}"
    sources = "\n".join(p.read_text() for p in (theme / "app").rglob("*.ts*"))
    assert "cdn.jsdelivr" not in sources and "cdnjs" not in sources and "[KatexCSS]" not in sources
    myst = (ROOT / "book" / "myst.yml").read_text()
    assert "template: ../book-theme" in myst
    for page in ("index.md", "notebooks/*.ipynb", "reproduction.md", "benchmarks.md"):
        assert page in myst, f"book/myst.yml does not list {page}"
