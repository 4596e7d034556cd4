"""Run the compendium's notebooks: papermill for ``make figures``, nbclient for
the tests (``python -m mutual.compendium.notebooks [--quick] NOTEBOOK...``).

Every notebook has exactly one cell tagged ``parameters`` that declares
``quick``; a run that passes a parameter the notebook does not declare, or a
notebook that raises, stops with a message naming the notebook and the cell.
"""

import argparse
import sys
from pathlib import Path

import nbformat

from .paths import BUILD, NOTEBOOKS

KERNEL = "mutual"
CELL_TIMEOUT = 1800  # seconds per cell


class NotebookError(RuntimeError):
    """A notebook failed to run; the message names the notebook and the cell."""


def declared_parameters(path):
    """Names and defaults of the notebook's ``parameters`` cell, checked for the conventions."""
    from papermill.inspection import inspect_notebook

    path = Path(path)
    nb = nbformat.read(path, as_version=4)
    tagged = [c for c in nb.cells if "parameters" in c.get("metadata", {}).get("tags", [])]
    if len(tagged) != 1:
        raise ValueError(f"{path.name}: needs exactly one cell tagged 'parameters', found {len(tagged)}")
    declared = {name: p["default"] for name, p in inspect_notebook(str(path)).items()}
    if "quick" not in declared:
        raise ValueError(f"{path.name}: its parameters cell must declare 'quick'")
    return declared


def _check_parameters(path, parameters):
    declared = declared_parameters(path)
    unknown = sorted(set(parameters) - set(declared))
    if unknown:
        raise ValueError(f"{Path(path).name}: no parameter named {', '.join(map(repr, unknown))} "
                         f"(its parameters cell declares {', '.join(declared)})")


def _cell_label(path, source):
    """'code cell N (first line)' for the cell of ``path`` whose source is ``source``."""
    cells = [c.source for c in nbformat.read(path, as_version=4).cells if c.cell_type == "code"]
    number = cells.index(source) + 1 if source in cells else "?"
    first = source.strip().splitlines()[0] if source.strip() else ""
    return f"code cell {number} ({first[:60]!r})"


def run_papermill(path, output, parameters=None):
    """Execute ``path`` with papermill into ``output`` (the ``make figures`` path)."""
    import papermill
    from papermill.exceptions import PapermillExecutionError

    parameters = dict(parameters or {})
    _check_parameters(path, parameters)
    Path(output).parent.mkdir(parents=True, exist_ok=True)
    try:
        papermill.execute_notebook(str(path), str(output), parameters=parameters, kernel_name=KERNEL,
                                   execution_timeout=CELL_TIMEOUT, cwd=str(NOTEBOOKS), progress_bar=True)
    except PapermillExecutionError as err:
        raise NotebookError(f"notebook {Path(path).name} failed in {_cell_label(path, err.source)}: "
                            f"{err.ename}: {err.evalue}") from None


def execute(path, parameters=None, timeout=600):
    """Execute ``path`` in a fresh kernel with nbclient (the tests' path); return the notebook."""
    from nbclient import NotebookClient
    from nbclient.exceptions import CellExecutionError
    from papermill.iorw import load_notebook_node
    from papermill.parameterize import parameterize_notebook

    parameters = dict(parameters or {})
    _check_parameters(path, parameters)
    nb = parameterize_notebook(load_notebook_node(str(path)), parameters, kernel_name=KERNEL)
    client = NotebookClient(nb, kernel_name=KERNEL, timeout=timeout,
                            resources={"metadata": {"path": str(NOTEBOOKS)}})
    try:
        client.execute()
    except CellExecutionError as err:
        failing = next((c.source for c in nb.cells if c.cell_type == "code"
                        and any(o.get("output_type") == "error" for o in c.get("outputs", []))), "")
        raise NotebookError(f"notebook {Path(path).name} failed in {_cell_label(path, failing)}: "
                            f"{err.ename}: {err.evalue}") from None
    return nb


def ordered(paths):
    """Chapter notebooks in number order, then the overview (it renders their results)."""
    paths = sorted(Path(p) for p in paths)
    return [p for p in paths if not p.name.startswith("00_")] + [p for p in paths if p.name.startswith("00_")]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("notebooks", nargs="+", type=Path)
    parser.add_argument("--quick", action="store_true", help="small, fast parameters (as in CI)")
    args = parser.parse_args(argv)
    todo = ordered(args.notebooks)
    for i, path in enumerate(todo, 1):
        print(f"==> [{i}/{len(todo)}] running {path.name}" + (" (quick)" if args.quick else ""), flush=True)
        try:
            run_papermill(path, BUILD / path.name, {"quick": True} if args.quick else {})
        except (NotebookError, ValueError) as err:
            sys.exit(f"make figures: {err}")


if __name__ == "__main__":
    main()
