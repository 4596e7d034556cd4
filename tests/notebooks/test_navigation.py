"""Every notebook links its neighbours and names the thesis sections it implements. The second cell of each
notebook is a markdown navigation cell (it starts with ``<!-- navigation``): a link back to the previous
notebook, on to the next (after the last one: the reproduction report), to the overview, and the thesis
sections and equations."""

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))
REPORT = "../figures/REPRODUCTION.md"
MARKER = "<!-- navigation"
_LINK = re.compile(r"\]\(([^)\s]+)\)")


def source(cell):
    return "".join(cell["source"]) if isinstance(cell["source"], list) else cell["source"]


def navigation(path):
    cells = json.loads(path.read_text())["cells"]
    assert len(cells) > 1 and cells[1]["cell_type"] == "markdown" and source(cells[1]).startswith(MARKER), (
        f"{path.name}: its second cell (right after the title) must be the markdown navigation cell "
        f"starting with {MARKER!r}: links to the previous and next notebooks and the thesis sections it implements")
    return source(cells[1])


def links(text):
    return [target.split("#")[0] for target in _LINK.findall(text) if not re.match(r"^[a-z]+:", target)]


@pytest.mark.parametrize("index", range(len(NOTEBOOKS)), ids=[p.stem for p in NOTEBOOKS])
def test_notebook_links_its_neighbours_and_names_the_thesis(index):
    path = NOTEBOOKS[index]
    text = navigation(path)
    targets = links(text)
    previous = NOTEBOOKS[index - 1].name if index > 0 else None
    following = NOTEBOOKS[index + 1].name if index + 1 < len(NOTEBOOKS) else REPORT
    if previous:
        assert previous in targets, f"{path.name}: the navigation cell does not link the previous notebook {previous}"
        assert "00_overview.ipynb" in targets, f"{path.name}: the navigation cell does not link the overview"
    assert following in targets, f"{path.name}: the navigation cell does not link the next page {following}"
    if previous:
        assert targets.index(previous) < targets.index(following), f"{path.name}: previous must come before next"
    for target in targets:
        assert (path.parent / target).exists(), f"{path.name}: the navigation cell links {target}, which is not there"
    assert re.search(r"\*Thesis[^*]*:\*", text), f"{path.name}: the navigation cell must name the thesis sections (*Thesis ...:*)"
    if previous:
        assert re.search(r"§\d\.\d", text), f"{path.name}: the navigation cell names no thesis section (§N.M)"


def test_overview_links_every_notebook():
    cells = json.loads((ROOT / "notebooks" / "00_overview.ipynb").read_text())["cells"]
    text = "\n".join(source(c) for c in cells if c["cell_type"] == "markdown")
    linked = set(links(text))
    missing = [p.name for p in NOTEBOOKS if not p.name.startswith("00_") and p.name not in linked]
    assert not missing, f"00_overview.ipynb does not link {', '.join(missing)}"
