"""The notebook runner attributes a write to the committed folders only to the run that made it: a quick run
into scratch that writes data/ itself is named, while one during which a full run (another process holding
figures/, as ``make figures`` does) wrote the committed files passes."""

import nbformat
import pytest

from mutual.compendium import notebooks, paths


def _notebook(folder, code):
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "mutual", "display_name": "Python (mutual)", "language": "python"}
    nb.cells = [nbformat.v4.new_code_cell("quick = False"), nbformat.v4.new_code_cell(code)]
    nb.cells[0].metadata["tags"] = ["parameters"]
    nbformat.write(nb, folder / "99_writer.ipynb")
    return folder / "99_writer.ipynb"


@pytest.fixture
def committed(tmp_path, monkeypatch):
    for name in ("data", "figures", "executed"):
        (tmp_path / name).mkdir()
    monkeypatch.setattr(paths, "DATA", tmp_path / "data")
    monkeypatch.setattr(paths, "FIGURES", tmp_path / "figures")
    monkeypatch.setattr(notebooks, "COMMITTED_RUN", tmp_path / "executed" / "running.json")
    return tmp_path


WRITE = "open({target!r}, 'w').write('x')"
FULL_RUN = ("from mutual.compendium.lock import output_lock\n"
            "with output_lock({figures!r}, {info!r}, 'full', ['01.ipynb'], {{}}):\n"
            "    open({target!r}, 'w').write('x')")


@pytest.mark.parametrize("writer, blamed", [(WRITE, True), (FULL_RUN, False)],
                         ids=["the notebook itself", "a full run in another process"])
def test_only_the_run_that_wrote_the_committed_files_is_blamed(committed, writer, blamed):
    target = str(committed / "data" / "ch3_demonstrations.csv")
    path = _notebook(committed, writer.format(target=target, figures=str(committed / "figures"),
                                              info=str(committed / "executed" / "running.json")))
    if blamed:
        with pytest.raises(notebooks.NotebookError, match="99_writer.ipynb wrote the committed .*ch3_demonstrations"):
            notebooks.execute(path, {"quick": True})
    else:
        notebooks.execute(path, {"quick": True})
