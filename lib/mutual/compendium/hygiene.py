"""Notebooks reach git without outputs, and exploring them never dirties the repository.

One definition of a *stripped* notebook (nbstripout's ``strip_output``: no outputs, no execution
counts, cell ids kept, JupyterLab's volatile metadata dropped) serves three places:

* the git clean filter that ``make env`` installs (``.gitattributes``: ``*.ipynb
  filter=nbstripout``): ``python -m mutual.compendium.hygiene`` reads a notebook on stdin and writes
  it stripped, so ``git add`` never stages outputs (``--textconv FILE`` for ``git diff``);
* the pre-save hook of ``make lab`` (:func:`strip_before_save`): the lab saves ``notebooks/*.ipynb``
  stripped, byte-identical to the committed file after a run, so ``git status`` stays clean;
* the tests, which check what would be committed (:func:`committed_text`).
"""

import copy
import subprocess
import sys
from pathlib import Path

import nbformat

from .paths import ROOT

# nbstripout's default volatile keys, plus the kernel's language details that JupyterLab fills in
EXTRA_KEYS = ["metadata.signature", "metadata.widgets", "cell.metadata.collapsed", "cell.metadata.ExecuteTime",
              "cell.metadata.execution", "cell.metadata.heading_collapsed", "cell.metadata.hidden",
              "cell.metadata.scrolled", "metadata.language_info.codemirror_mode",
              "metadata.language_info.file_extension", "metadata.language_info.mimetype",
              "metadata.language_info.nbconvert_exporter", "metadata.language_info.pygments_lexer",
              "metadata.language_info.version"]
FILTER = "nbstripout"  # the filter's name in .gitattributes and the git config


def strip(nb):
    """A copy of the notebook node ``nb`` without outputs, execution counts or volatile metadata."""
    from nbstripout import strip_output

    return strip_output(copy.deepcopy(nb), keep_output=False, keep_count=False, keep_id=True, extra_keys=EXTRA_KEYS)


def stripped_text(text):
    """The notebook JSON ``text`` as the clean filter writes it."""
    out = nbformat.writes(strip(nbformat.reads(text, as_version=nbformat.NO_CONVERT)))
    return out if out.endswith("\n") else out + "\n"  # as nbformat.write does


def dirty_cells(text):
    """Numbers of the code cells (1-based) that carry outputs or execution counts in notebook ``text``."""
    cells = [c for c in nbformat.reads(text, as_version=4).cells if c.cell_type == "code"]
    return [i for i, c in enumerate(cells, 1) if c.get("outputs") or c.get("execution_count")]


def _git(*args, check=True):
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, check=check)


def filter_installed():
    """Whether git will run the clean filter on the repository's notebooks."""
    try:
        attr = _git("check-attr", "filter", "notebooks/00_overview.ipynb", check=False).stdout
        clean = _git("config", "--get", f"filter.{FILTER}.clean", check=False).stdout.strip()
    except FileNotFoundError:
        return False
    return attr.strip().endswith(f": {FILTER}") and bool(clean)


def committed_text(path):
    """What ``git add path`` would stage: the working file through the clean filter when git has it,
    else the working file as it is."""
    text = Path(path).read_text()
    return stripped_text(text) if filter_installed() else text


def staged_text(path):
    """The notebook as staged in git's index (``git show :path``), or None outside git."""
    try:
        out = _git("show", f":{Path(path).resolve().relative_to(ROOT)}", check=False)
    except (FileNotFoundError, ValueError):
        return None
    return out.stdout if out.returncode == 0 else None


def strip_before_save(model, path, contents_manager=None, **kwargs):
    """JupyterLab pre-save hook (``make lab``): save the compendium's notebooks (``notebooks/``)
    stripped, as they are committed; the browser keeps showing the outputs until the page reloads."""
    if model.get("type") == "notebook" and path.lstrip("/").startswith("notebooks/") and model.get("content"):
        content = model["content"]
        nb = content if isinstance(content, nbformat.NotebookNode) else nbformat.from_dict(content)
        model["content"] = strip(nb)


def main(argv=None):
    """The git clean filter (stdin to stdout), or ``--textconv FILE`` for ``git diff``."""
    argv = sys.argv[1:] if argv is None else argv
    text = Path(argv[1]).read_text() if argv[:1] == ["--textconv"] else sys.stdin.read()
    sys.stdout.write(stripped_text(text))


if __name__ == "__main__":
    main()
