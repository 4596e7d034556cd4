"""The benchmark's cases: systems x demonstrators x truths, split into development and held-out.

Per system (:data:`.setups.SETUPS`) nine cases, the same design for each (``DESIGN``): the truth
(``A``/``B`` approached, ``F`` far, ``U`` none), the demonstrator kind (:data:`.demonstrators.KINDS`)
and the start distribution ("narrow" or "wide"); 20 demonstrations each. Per system one ``A``, one
``B`` and one ``U`` case are held out, drawn with the fixed seed ``SPLIT_SEED`` (:func:`split_of`):
24 development cases to tune on, 12 held-out cases nobody tunes on. Two cases (``VIA_CLI``) are
run through the command line, as a user would.

:func:`case_recording` makes a case's demonstrations (:mod:`.demonstrators`), writes them as the
documented trajectory CSV and reads them back with the library's reader, exactly as a user's file
would be read; the CSV is cached (``$MUTUAL_CACHE_DIR/continuous-benchmark``) under a key of the
case and of the demonstrators' source code, so an edit of a demonstrator makes new files.
"""

import hashlib
import tempfile
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ....cache import cache_folder
from ..recordings import read_recording, write_recording
from . import demonstrators
from .setups import SETUPS

#: (truth, demonstrator kind, start distribution) of the nine cases of every system
DESIGN = (("A", "filter", "narrow"), ("A", "noisy", "wide"), ("A", "random20", "narrow"), ("A", "mppi", "wide"),
          ("B", "filter", "wide"), ("B", "lagged", "narrow"), ("F", "mppi", "narrow"), ("U", "noisy", "narrow"),
          ("U", "lagged", "wide"))
SPLIT_SEED = 2026
DEMONSTRATIONS = 20
#: cases run through ``mutual constraints infer-continuous`` instead of the Python API
VIA_CLI = ("pendulum-A-filter-narrow", "car-A-filter-narrow")
#: systems whose recordings carry no control columns (the inference then infers the controls)
WITHOUT_CONTROLS = ("car",)


@dataclass(frozen=True)
class Case:
    """One benchmark case: ``system`` (a key of SETUPS), ``truth`` key, demonstrator ``kind``, start
    distribution ``starts``, the ``split`` ("development" or "held-out"), demonstrations ``n``."""

    system: str
    truth: str
    kind: str
    starts: str
    split: str
    n: int = DEMONSTRATIONS

    @property
    def id(self):
        return f"{self.system}-{self.truth}-{self.kind}-{self.starts}"

    @property
    def seed(self):
        return zlib.crc32(self.id.encode()) & 0xFFFF

    @property
    def setup(self):
        return SETUPS[self.system]

    @property
    def truth_text(self):
        return "; ".join(self.setup.truths[self.truth]) or "none"

    @property
    def via_cli(self):
        return self.id in VIA_CLI

    def regions(self):
        """The hidden regions (an empty list for an unconstrained case)."""
        return self.setup.truth(self.truth)


def split_of(system):
    """Per design row of ``system``: "held-out" for one A, one B and one U row drawn with SPLIT_SEED."""
    rng = np.random.default_rng([SPLIT_SEED, list(SETUPS).index(system)])
    held = set()
    for truth in ("A", "B", "U"):
        rows = [i for i, row in enumerate(DESIGN) if row[0] == truth]
        held.add(rows[int(rng.integers(len(rows)))])
    return ["held-out" if i in held else "development" for i in range(len(DESIGN))]


def all_cases():
    """Every case, system by system in the order of SETUPS, then by DESIGN."""
    return [Case(system, *row, split) for system in SETUPS for row, split in zip(DESIGN, split_of(system))]


def cases(split="development", systems=None):
    """The cases of ``split`` ("development", "held-out" or "all"), optionally of some ``systems``."""
    if split not in ("development", "held-out", "all"):
        raise ValueError(f"split: must be 'development', 'held-out' or 'all', got {split!r}")
    unknown = [s for s in (systems or ()) if s not in SETUPS]
    if unknown:
        raise ValueError(f"systems: unknown system {unknown[0]!r}; known: {', '.join(SETUPS)}")
    return [c for c in all_cases() if (split == "all" or c.split == split) and (not systems or c.system in systems)]


def _source_key():
    here = Path(__file__).parent
    files = [here / name for name in ("setups.py", "controllers.py", "safety.py", "demonstrators.py", "cases.py")]
    text = b"".join(f.read_bytes() for f in files + sorted((here / "systems").glob("*.toml")))
    return hashlib.sha256(text).hexdigest()[:16]


def case_csv(case, folder=None):
    """The path of the case's trajectory CSV, made if missing: in ``folder`` if given, else in the
    cache (or, where the cache cannot be used, a temporary folder)."""
    folder = Path(folder) if folder is not None else cache_folder("continuous-benchmark")
    if folder is None:
        folder = Path(tempfile.mkdtemp(prefix="continuous-benchmark-"))
    path = folder / f"{case.id}-{_source_key()}.csv"
    if not path.is_file():
        setup = case.setup
        x0 = demonstrators.starts(case.system, case.starts, case.n, case.seed)
        states, controls = demonstrators.rollout(setup, case.kind, case.regions(), x0, case.seed + 1)
        record = case.system not in WITHOUT_CONTROLS
        problem = setup.system_file().problem
        write_recording(path, demonstrators.recording(setup, states, controls, record, case.id),
                        problem.system.state_names, problem.system.control_names if record else None)
    return path


def case_recording(case, folder=None):
    """The case's demonstrations as the library reads them from its CSV (:func:`case_csv`)."""
    system = case.setup.system_file().problem.system
    return read_recording(case_csv(case, folder), system.state_names, system.control_names)
