"""The notebook lane: quick runs of the notebooks the collected tests need, one after another in a
background process (``python -m mutual.compendium.notebooks --quick``), while the unit tests run:
every notebook runs once per session. Alone, pytest runs the lane beside its tests; with
pytest-xdist (``make test``: ``-n``), the controller runs it and each worker reads its outcomes
from the files the lane writes (``<folder>/lane/<stem>.json``), so no worker waits on another."""

import inspect
import json
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

from mutual.atomic import atomic_path
from mutual.compendium.paths import NOTEBOOKS

CALLS = re.compile(r"executed_notebook\(\s*[\"'](\d\d_\w+)[\"']")
STOPPED = (1, ["the session stopped before this notebook ran"])


def lane_order(stems):
    """The order the lane runs them: by number, the overview last (it renders the others' results)."""
    return [s for s in sorted(stems) if not s.startswith("00_")] + sorted(s for s in stems if s.startswith("00_"))


def _stems_of(item):
    stem = getattr(item, "callspec", None) and item.callspec.params.get("stem")
    return [stem] if stem else CALLS.findall(inspect.getsource(item.function))


def _uses_a_notebook(item):
    return "executed_notebook" in getattr(item, "fixturenames", ())


def needed_notebooks(items):
    """Stems of the notebooks the collected tests use (a ``stem`` parameter, or a literal call)."""
    stems = {stem for item in items if _uses_a_notebook(item) for stem in _stems_of(item)}
    if any(s.startswith("00_") for s in stems):
        stems |= {p.stem for p in NOTEBOOKS.glob("[0-9][0-9]_*.ipynb")}
    return lane_order(stems)


def sort_for_the_lane(items, stems):
    """Unit tests first; then the tests that read a notebook's run, in the order the lane runs them."""
    order = {stem: i for i, stem in enumerate(stems)}

    def key(item):
        if not _uses_a_notebook(item):
            return -1
        return max((order.get(s, len(order)) for s in _stems_of(item)), default=len(order))
    items.sort(key=key)


class NotebookLane:
    """Runs the quick notebooks in a background thread, each in its own process, into ``folder``;
    each outcome also goes to ``folder/lane/<stem>.json`` for the workers of a pytest-xdist run."""

    def __init__(self, stems, folder):
        self.stems, self.folder = list(stems), Path(folder)
        self.done = {stem: threading.Event() for stem in self.stems}
        self.outcome, self.process, self.stopped = {}, None, False
        self.seconds, self.waited = {}, 0.0
        self.thread = threading.Thread(target=self._run, daemon=True, name="notebook lane")

    def _finish(self, stem, outcome):
        self.outcome[stem] = outcome
        self.done[stem].set()
        try:
            with atomic_path(self.folder / "lane" / f"{stem}.json") as partial:  # a worker reads all or nothing
                partial.write_text(json.dumps(list(outcome)))
        except OSError:
            pass  # the workers stop waiting at their deadline

    def _run(self):
        try:
            for stem in self.stems:
                if self.stopped:
                    break
                command = [sys.executable, "-m", "mutual.compendium.notebooks", "--quick", "--output",
                           str(self.folder), str(NOTEBOOKS / f"{stem}.ipynb")]
                start = time.monotonic()
                self.process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                out, err = self.process.communicate()
                self.seconds[stem] = time.monotonic() - start
                self._finish(stem, (self.process.returncode, (err.strip() or out.strip()).splitlines()[-1:]))
        finally:  # whatever happened, nobody waits forever
            for stem in self.stems:
                if stem not in self.outcome:
                    self._finish(stem, STOPPED)

    def start(self):
        self.thread.start()

    def wait(self, stem):
        start = time.monotonic()
        self.done[stem].wait()
        self.waited += time.monotonic() - start
        return self.outcome.get(stem, STOPPED)

    def stop(self):
        self.stopped = True
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)   # gone before the session's output folder is removed
            except subprocess.TimeoutExpired:
                self.process.kill()
        if not self.thread.is_alive():
            for stem in self.stems:
                if stem not in self.outcome:
                    self._finish(stem, STOPPED)


class LaneOutcomes:
    """A pytest-xdist worker's view of the controller's lane: waits for ``folder/lane/<stem>.json``."""

    def __init__(self, stems, folder, deadline=3600.0):
        self.done, self.folder, self.waited = dict.fromkeys(stems), Path(folder), 0.0
        self.deadline, self.controller = deadline, os.getppid()

    def wait(self, stem, poll=0.2):
        """The outcome of ``stem``'s run; a failure if the lane's folder was removed, the controller is gone or an
        hour passed without one."""
        path, start = self.folder / "lane" / f"{stem}.json", time.monotonic()
        while not path.exists():
            if not self.folder.is_dir():
                return 1, [f"the notebook lane's folder {self.folder} was removed while the tests ran"]
            if os.getppid() != self.controller or time.monotonic() - start > self.deadline:
                return 1, ["the notebook lane gave no outcome for this notebook (its controller stopped or hung)"]
            time.sleep(poll)
        self.waited += time.monotonic() - start
        return tuple(json.loads(path.read_text()))
