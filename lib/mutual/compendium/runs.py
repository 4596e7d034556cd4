"""Run records: what a results file says about the run that wrote it.

The notebook runner passes the run's mode, the notebook's path and a hash of its code to the
kernel in environment variables; :func:`mutual.compendium.results.write_results` copies them into
the results file as ``"run"``; the report refuses results whose notebook's code changed since
(older than their notebook), results whose notebook is gone, and, for the committed report,
results of anything but a full run.

Modes: ``full`` (the notebook's own parameters), ``quick`` (``quick=True`` only), ``custom`` (other
parameters) and ``interactive`` (written outside the runner, e.g. in JupyterLab).
"""

import hashlib
import json
import os
from pathlib import Path

import nbformat

from .paths import NOTEBOOKS, ROOT

ENV_MODE = "MUTUAL_RUN_MODE"
ENV_NOTEBOOK = "MUTUAL_NOTEBOOK"
ENV_SHA = "MUTUAL_NOTEBOOK_SHA256"
ENV_PARAMETERS = "MUTUAL_RUN_PARAMETERS"
MODES = ("full", "quick", "custom", "interactive")


class StaleResults(ValueError):
    """A results file the report must not use; the message names the file and its notebook."""


def code_sha256(path) -> str:
    """SHA-256 of the notebook's code cells (their sources only: outputs, metadata and markdown
    do not change what a run computes)."""
    nb = nbformat.read(str(path), as_version=4)
    code = [c.source for c in nb.cells if c.cell_type == "code"]
    return hashlib.sha256(json.dumps(code).encode()).hexdigest()


def run_mode(parameters) -> str:
    """``full``, ``quick`` or ``custom`` for a run with these overridden parameters."""
    parameters = dict(parameters or {})
    if not parameters or parameters == {"quick": False}:
        return "full"
    return "quick" if parameters == {"quick": True} else "custom"


def shown(path) -> str:
    """``path`` relative to the repository when inside it (so records do not depend on the checkout)."""
    path = Path(path).resolve()
    try:
        return str(path.relative_to(ROOT))
    except ValueError:
        return str(path)


def current_mode() -> str:
    """The mode of the run this process belongs to: the runner's, which its kernels carry with the notebook's path,
    else ``interactive`` (a lab, a script)."""
    if not os.environ.get(ENV_NOTEBOOK):
        return "interactive"
    return os.environ.get(ENV_MODE, "custom")


def kernel_env(path, parameters) -> dict:
    """Environment variables that tell a kernel which run it belongs to."""
    return {ENV_MODE: run_mode(parameters), ENV_NOTEBOOK: str(Path(path).resolve()),
            ENV_SHA: code_sha256(path), ENV_PARAMETERS: json.dumps(dict(parameters or {}), sort_keys=True)}


def run_record(notebook: str) -> dict:
    """The ``"run"`` entry for results written now by ``notebook`` (its file's stem)."""
    runner_path = os.environ.get(ENV_NOTEBOOK)
    if runner_path:
        if Path(runner_path).stem != notebook:
            raise ValueError(f"write_results({notebook!r}) called from notebook {Path(runner_path).name}: "
                             f"name the results after the notebook's file ({Path(runner_path).stem!r})")
        return {"mode": current_mode(), "notebook": shown(runner_path),
                "code_sha256": os.environ.get(ENV_SHA) or code_sha256(runner_path),
                "parameters": json.loads(os.environ.get(ENV_PARAMETERS) or "{}")}
    path = NOTEBOOKS / f"{notebook}.ipynb"
    if not path.exists():
        raise ValueError(f"write_results({notebook!r}): no notebook {shown(path)}; name the results after "
                         "the notebook's file")
    return {"mode": "interactive", "notebook": shown(path), "code_sha256": code_sha256(path), "parameters": {}}


def check_record(doc: dict, label: str, committed: bool) -> dict:
    """Raise :class:`StaleResults` unless the results ``doc`` (read from ``label``) may be used."""
    run = doc.get("run")
    if not isinstance(run, dict) or run.get("mode") not in MODES:
        raise StaleResults(f"{label}: written before runs were recorded (no run record); re-run its notebook "
                           f"({doc.get('notebook', '?')}.ipynb)")
    path = Path(run["notebook"])
    path = path if path.is_absolute() else ROOT / path
    if not path.exists():
        raise StaleResults(f"{label}: its notebook {run['notebook']} no longer exists; delete the results file")
    if code_sha256(path) != run["code_sha256"]:
        raise StaleResults(f"{label}: older than its notebook {run['notebook']} (its code changed after the run); "
                           f"re-run it: python -m mutual.compendium.notebooks {run['notebook']}, or `make figures`")
    if committed and run["mode"] != "full":
        raise StaleResults(f"{label}: written by a {run['mode']} run of {run['notebook']}; the committed report "
                           "takes full runs only (`make figures`)")
    return run


def quiet_progress_bars():
    """Switch tqdm progress bars off in this process, even where a library asks for one explicitly
    (``TQDM_DISABLE=1`` only changes tqdm's default). The runner calls this at the start of every
    kernel it starts, so batch runs print no progress bars into the executed notebooks."""
    import tqdm.std

    if getattr(tqdm.std.tqdm.__init__, "quiet", False):
        return
    loud = tqdm.std.tqdm.__init__

    def quiet(self, *args, **kwargs):
        kwargs["disable"] = True
        loud(self, *args, **kwargs)

    quiet.quiet = True
    tqdm.std.tqdm.__init__ = quiet
