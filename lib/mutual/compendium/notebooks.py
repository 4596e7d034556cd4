"""Run the compendium's notebooks, for ``make figures`` and the tests alike::

    python -m mutual.compendium.notebooks [--quick] [-p NAME=VALUE ...] [--output DIR] NOTEBOOK...

* Every notebook has exactly one cell tagged ``parameters`` that declares ``quick``; a parameter
  the notebook does not declare is refused.
* Outputs go to ``--output`` (default ``$MUTUAL_OUTPUT_DIR``, else the scratch folder
  ``build/scratch``). Only a full run may write the committed ``figures/`` (``make figures``
  passes ``--output figures``); a quick run or one with other parameters there is refused.
* A notebook's previous results are deleted before it runs, so a notebook that fails leaves
  none for the report to use; the results record the run (:mod:`.runs`).
* A notebook that raises, a kernel that dies, a cell that times out, a missing notebook: one line
  naming the notebook and the cell (the executed copy keeps the traceback).
* SIGINT and SIGTERM interrupt the running cell (so its atomic writes clean up after themselves),
  shut the kernel down, remove temporary files a killed kernel left behind, and stop with one line.
* Kernels run with ``TQDM_DISABLE=1``: no progress bars in the executed notebooks, and with numpy's
  and OpenBLAS's code paths pinned to x86-64 with AVX2 (:mod:`.numerics`): the same bits on every
  such machine.
* One runner per output folder: a second one stops at once, naming the first (:mod:`.lock`).
"""

import argparse
import ast
import asyncio
import os
import re
import signal
import sys
import time
from pathlib import Path

import nbformat

from ..atomic import write_text
from . import paths as _paths
from .kernel import KERNEL, KernelRun, route_signals
from .lock import COMMITTED_RUN, OutputBusy, check_output_folder, disk_error, output_lock, writers
from .numerics import portable_env
from .paths import OUTPUT_ENV, executed_dir, figures_dir, generated_data_dir, is_committed, results_dir
from .runs import kernel_env, run_mode, shown

CELL_TIMEOUT = 3600      # seconds per cell (notebook 09 runs the continuous benchmark, 24 cases x 3 methods, in one cell)
KERNEL_ENV = {"TQDM_DISABLE": "1", "PYDEVD_DISABLE_FILE_VALIDATION": "1"}
_TEMPORARY = re.compile(r"^\..+\.[a-z0-9_]{8}(\.[A-Za-z0-9]+)?$")  # mutual.atomic's temporary files


class NotebookError(RuntimeError):
    """A notebook failed to run; the message names the notebook and the cell."""


class Interrupted(KeyboardInterrupt):
    """The run was stopped by SIGINT or SIGTERM; ``signum`` says which."""

    def __init__(self, message, signum):
        super().__init__(message)
        self.signum = signum


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


def _prepared(path, parameters):
    """The notebook with ``parameters`` injected after its parameters cell (papermill's way)."""
    from papermill.iorw import load_notebook_node
    from papermill.parameterize import parameterize_notebook

    declared = declared_parameters(path)
    unknown = sorted(set(parameters) - set(declared))
    if unknown:
        raise ValueError(f"{path.name}: no parameter named {', '.join(map(repr, unknown))} "
                         f"(its parameters cell declares {', '.join(declared)})")
    if not parameters:
        return nbformat.read(path, as_version=4)
    return parameterize_notebook(load_notebook_node(str(path)), parameters, kernel_name=KERNEL)


def _cell_label(nb, index):
    """'code cell N (first line)', numbering the notebook's own code cells (not the injected one)."""
    if index is None:
        return "kernel start-up"
    cell = nb.cells[index]
    if "injected-parameters" in cell.metadata.get("tags", []):
        return "the injected parameters cell"
    number = sum(c.cell_type == "code" and "injected-parameters" not in c.metadata.get("tags", [])
                 for c in nb.cells[:index + 1])
    first = cell.source.strip().splitlines()[0] if cell.source.strip() else ""
    return f"code cell {number} ({first[:60]!r})"


def committed_files():
    """``{path: (mtime, size)}`` of the committed outputs (``figures/`` and ``data/``), to tell whether a
    run that must not write them did (unless a full run wrote meanwhile: :func:`.lock.writers`)."""
    found = {}
    for folder in (_paths.FIGURES, _paths.DATA):
        for path in (folder.rglob("*") if folder.is_dir() else []):
            if path.is_file():
                stat = path.stat()
                found[path] = (stat.st_mtime_ns, stat.st_size)
    return found


def temporaries(since):
    """Temporary files of :mod:`mutual.atomic` created since ``since`` (a time) in the output folders."""
    found = []
    for folder in {figures_dir().resolve(), generated_data_dir().resolve()}:
        if folder.is_dir():
            found += [p for p in folder.rglob(".*") if p.is_file() and _TEMPORARY.match(p.name)
                      and p.stat().st_mtime >= since - 1]
    return sorted(found)


def execute(path, parameters=None, timeout=CELL_TIMEOUT, env=None):
    """Execute the notebook ``path`` in a fresh ``mutual`` kernel with ``parameters`` overridden and
    return the executed notebook; its copy goes to :func:`~.paths.executed_dir`.

    Raises :class:`NotebookError` (naming the notebook and the cell) when a cell raises or times
    out or the kernel dies, ValueError for undeclared parameters, and :class:`Interrupted` on
    SIGINT/SIGTERM. ``env`` adds environment variables for the kernel. A full disk, a read-only
    output folder or one that is a file is a NotebookError in one line; so is an output folder another
    runner holds (:mod:`.lock`).
    """
    path, parameters = Path(path), dict(parameters or {})
    if not path.is_file():
        raise NotebookError(f"no notebook at {shown(path)}")
    mode = run_mode(parameters)
    if is_committed() and mode != "full":
        raise NotebookError(f"{path.name}: a {mode} run never writes the committed figures/ (only `make figures` "
                            "does); leave the output folder at its default, build/scratch")
    nb = _prepared(path, parameters)
    try:
        check_output_folder(figures_dir())
        with output_lock(figures_dir(), executed_dir() / "running.json", mode, [path], parameters):
            return _execute(nb, path, parameters, timeout, env, mode)
    except OSError as err:
        raise NotebookError(f"notebook {path.name}: {disk_error(err)}") from None


def _execute(nb, path, parameters, timeout, env, mode):
    """:func:`execute` once the output folder is checked and held."""
    from jupyter_core.utils import ensure_event_loop
    from nbclient.exceptions import CellExecutionError, CellTimeoutError, DeadKernelError

    results = (results_dir() / f"{path.stem}.json", results_dir() / "extensions" / f"{path.stem}.json")
    for stale in results:
        stale.unlink(missing_ok=True)
    kernel = {**os.environ, **KERNEL_ENV, **portable_env(), OUTPUT_ENV: str(figures_dir().resolve()),
              **kernel_env(path, parameters), **(env or {})}
    guarded = None if is_committed() else (committed_files(), writers(COMMITTED_RUN))
    loop = ensure_event_loop()
    log_path = executed_dir() / f"{path.stem}.kernel.log"
    log_path.parent.mkdir(parents=True, exist_ok=True)
    log = open(log_path, "w")  # the kernel process's own messages (cell output goes to the notebook)
    run = KernelRun(nb, path, timeout, kernel, loop, log)
    restore = route_signals(run)
    started, error = time.time(), None
    try:
        run.task = loop.create_task(run.cells())
        loop.run_until_complete(run.task)
    except CellExecutionError as err:
        error = f"{err.ename}: {err.evalue}"
    except CellTimeoutError:
        error = f"timed out after {timeout} s"
    except DeadKernelError:
        error = "the kernel died"
    except asyncio.CancelledError:
        error = "stopped"
    except Exception as err:  # noqa: BLE001 (kernel start-up: no such kernel, a port clash)
        error = f"{type(err).__name__}: {err}"
    finally:
        loop.run_until_complete(run.shutdown())
        log.close()
        restore()
        removed = temporaries(started) if (run.signum or run.killed or run.exit_status is not None) else []
        for leftover in removed:
            leftover.unlink(missing_ok=True)
        unsaved = _save_executed(nb, path)
    if run.signum is not None or error:  # results of a run that did not finish are not results
        for partial in results:
            partial.unlink(missing_ok=True)
    where = f"notebook {path.name}, {_cell_label(nb, run.cell)}"
    cleaned = f"; removed {len(removed)} temporary file(s) the kernel left" if removed else ""
    if unsaved and not error and run.signum is None:
        raise NotebookError(f"notebook {path.name} ran, but {unsaved}")
    cleaned += f"; {unsaved}" if unsaved else ""
    if run.signum is not None:
        raise Interrupted(f"stopped by {signal.Signals(run.signum).name} in {where}; it left no results{cleaned}",
                          run.signum)
    if error == "the kernel died" or (error and run.exit_status is not None):
        raise NotebookError(f"{where}: the kernel died ({run.death()}; its log: {shown(log_path)}){cleaned}")
    if error:
        raise NotebookError(f"notebook {path.name} failed in {_cell_label(nb, run.cell)}: {error}{cleaned}")
    if guarded is not None:
        (before, others), after = guarded, committed_files()
        touched = sorted(shown(f) for f in set(before) | set(after) if before.get(f) != after.get(f))
        if touched and others == writers(COMMITTED_RUN) and others[1] is None:   # no full run wrote meanwhile
            raise NotebookError(f"notebook {path.name} wrote the committed {', '.join(touched[:5])}"
                                f"{' ...' if len(touched) > 5 else ''} in a {mode} run (outputs go to "
                                f"{shown(figures_dir())}): write through figures_dir() and generated_data_dir()")
    return nb


def _save_executed(nb, path):
    """Save the executed copy; on a disk error, say so (one clause) instead of hiding the cell's error."""
    try:
        write_text(executed_dir() / path.name, nbformat.writes(nb))
    except OSError as err:
        return f"its executed copy was not saved ({disk_error(err)})"
    return ""


def ordered(paths):
    """Chapter notebooks in number order, then the overview (it renders their results)."""
    paths = sorted(Path(p) for p in paths)
    return [p for p in paths if not p.name.startswith("00_")] + [p for p in paths if p.name.startswith("00_")]


def _parameter(text):
    name, sep, value = text.partition("=")
    if not sep or not name.isidentifier():
        raise argparse.ArgumentTypeError(f"{text!r}: write NAME=VALUE, e.g. -p n_demos=50")
    try:
        return name, ast.literal_eval(value)
    except (ValueError, SyntaxError):
        return name, value


def _stop(signum, frame):
    raise Interrupted(f"stopped by {signal.Signals(signum).name} between notebooks", signum)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("notebooks", nargs="+", type=Path)
    parser.add_argument("--quick", action="store_true", help="small, fast parameters (as in the tests)")
    parser.add_argument("-p", "--parameter", type=_parameter, action="append", default=[], metavar="NAME=VALUE",
                        help="override a parameter of the notebooks' parameters cell (a Python literal)")
    parser.add_argument("--output", type=Path, help="output folder (default: $MUTUAL_OUTPUT_DIR, else build/scratch; "
                                                    "`make figures` passes figures)")
    args = parser.parse_args(argv)
    if args.output:
        os.environ[OUTPUT_ENV] = str(args.output.resolve())
    parameters = ({"quick": True} if args.quick else {}) | dict(args.parameter)
    todo = ordered(args.notebooks)
    signal.signal(signal.SIGTERM, _stop)
    try:
        missing = [p for p in todo if not p.is_file()]
        if missing:
            raise NotebookError(f"no notebook at {', '.join(shown(p) for p in missing)}")
        if is_committed() and run_mode(parameters) != "full":
            raise NotebookError("quick runs and runs with other parameters never write the committed figures/ "
                                "(only `make figures` does): leave the output folder at its default, build/scratch")
        check_output_folder(figures_dir())
        with output_lock(figures_dir(), executed_dir() / "running.json", run_mode(parameters), todo, parameters):
            _run_all(todo, parameters)
    except OSError as err:
        sys.exit(f"notebook runner: {disk_error(err)}")
    except Interrupted as err:
        print(f"notebook runner: {err}", file=sys.stderr)
        sys.exit(128 + err.signum)
    except KeyboardInterrupt:
        print("notebook runner: stopped by SIGINT between notebooks", file=sys.stderr)
        sys.exit(128 + signal.SIGINT)
    except (NotebookError, OutputBusy, ValueError) as err:
        sys.exit(f"notebook runner: {err}")


def _run_all(todo, parameters):
    print(f"==> {run_mode(parameters)} run, outputs to {shown(figures_dir())}", flush=True)
    for i, path in enumerate(todo, 1):
        print(f"==> [{i}/{len(todo)}] {path.name}", flush=True)
        start = time.time()
        execute(path, parameters)
        print(f"    done in {time.time() - start:.0f} s", flush=True)


if __name__ == "__main__":
    main()
