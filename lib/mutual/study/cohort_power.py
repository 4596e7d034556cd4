"""SIMULATED power of the chapter 5 study with its own generative model (Sec. 5.2-5.3.1).

A *cohort* is a stream of simulated recruits, each drawn from the documented supervisor types of
:func:`mutual.study.cohort.simulated_recruits` (Fig. 5.5's spread) in the proportions of a
``mix``, with the range of their judgement noise ``sigma`` (``cohort.SIGMA_RANGE``) scaled by ``noise_scale``. Each recruit goes through
the study exactly as in :func:`mutual.study.cohort.simulate_study`: Phase II interventions, the
maximum-likelihood fit (eq. 4.12), the exclusion rule (Sec. 5.2.1), then the six Phase III trials of
their row of the counterbalanced design (:func:`mutual.study.design.study_design`). Recruits are
drawn until ``n_max`` are analysed; the outcome per analysed participant is the mean number of
false positives per trial with each safe set.

Reusing draws across sample sizes: the cohort of size ``N`` is the first ``N`` analysed
participants of the stream. Participants are independent draws, so each prefix is a sample of ``N``
participants from the simulated population and every power estimate at one ``N`` is unbiased;
within one ``N`` the cohorts share no participant, so the binomial (Wilson) intervals hold. Across
``N`` the estimates are positively correlated (common random numbers): the curve is smoother than
independent estimates would be, and differences between sample sizes are estimated more precisely.
We do *not* resample a finite pool to make more cohorts at one ``N``: overlapping cohorts would make
the binomial intervals too narrow. One cohort's Phase III trials run in one batch (one random
stream), so a cohort depends on ``(setting, cohort index, n_max, seed)`` and on nothing else:
never on the worker that ran it.

The analysis of the simulated cohorts (the study notebook's, vectorized) is in :mod:`.power_summary`,
so that changing it never invalidates cached cohorts: :func:`code_version` hashes only the simulation's
sources (any edit to them, docstrings included, means new cohorts).
"""

import hashlib
import json
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..supervision import (TRUE_W_MAX, LibraryEdgeWarning, ValueFunction, ValueLibrary, fit_supervisor,
                           unsafe_set_contains)
from . import cohort as _cohort
from .design import TREATMENTS, study_design
from .teaming import Team, TeamingConfig, simulate_teaming

# recruits per 12 of each documented type (mutual.study.cohort.simulated_recruits); fixed before any run
MIXES = {
    "thesis": (("standard-like", 3), ("conservative-like", 3), ("gradual", 5), ("agile", 1)),  # Fig. 5.5
    "mostly-standard": (("standard-like", 9), ("conservative-like", 1), ("gradual", 1), ("agile", 1)),
    "mostly-gradual": (("standard-like", 1), ("conservative-like", 1), ("gradual", 9), ("agile", 1)),
}
DESIGN_SEED = 0           # the study notebook's design seed
FP_COLUMNS = tuple(f"fp_{t}" for t in TREATMENTS)
# what a simulated cohort depends on: these study modules and the whole chapter 4 package but its views
_SOURCES = ("study/cohort_power.py", "study/cohort.py", "study/teaming.py", "study/teaming_batch.py",
            "study/value_stack.py", "study/design.py", "supervision/*.py")
_NOT_SOURCES = ("supervision/explore.py",)


@dataclass(frozen=True)
class CohortSetting:
    """What the simulated population and study look like: the ``mix`` of supervisor types (a key of
    :data:`MIXES`), ``noise_scale`` (multiplies each recruit's judgement noise ``sigma``), Phase II
    scenes per recruit, Phase III trial length (s) and the value-function grid (quick or full)."""
    mix: str = "thesis"
    noise_scale: float = 1.0
    n_scenes: int = 40
    trial_seconds: float = 60.0
    quick_grid: bool = False

    def __post_init__(self):
        if self.mix not in MIXES:
            raise ValueError(f"mix must be one of {sorted(MIXES)}, got {self.mix!r}")
        if not (np.isfinite(self.noise_scale) and self.noise_scale > 0):
            raise ValueError(f"noise_scale must be a positive number, got {self.noise_scale!r}")
        if isinstance(self.n_scenes, bool) or int(self.n_scenes) != self.n_scenes or self.n_scenes < 2:
            raise ValueError(f"n_scenes must be an integer >= 2, got {self.n_scenes!r}")
        if not (np.isfinite(self.trial_seconds) and self.trial_seconds > 0):
            raise ValueError(f"trial_seconds must be a positive number, got {self.trial_seconds!r}")

    @property
    def label(self):
        return f"{self.mix} mix, noise x{self.noise_scale:g}"

    def words(self):
        """Four 32-bit words identifying the setting (sha256 of its fields): its seed's key."""
        digest = hashlib.sha256(json.dumps(asdict(self), sort_keys=True).encode()).digest()
        return tuple(int.from_bytes(digest[4 * i:4 * i + 4], "little") for i in range(4))


@dataclass(frozen=True)
class CohortTask:
    """One simulated cohort: ``n_max`` analysed participants of ``setting``, stream ``cohort``."""
    setting: CohortSetting
    cohort: int
    n_max: int
    seed: int = 0

    def __post_init__(self):
        for name, least in (("cohort", 0), ("n_max", 2), ("seed", 0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < least:
                raise ValueError(f"{name} must be an integer >= {least}, got {v!r}")

    def params(self):
        """Everything the cohort depends on (the cache key, with :func:`code_version`)."""
        return {"setting": asdict(self.setting), "cohort": int(self.cohort), "n_max": int(self.n_max),
                "seed": int(self.seed)}

    def seed_sequence(self, stream):
        """Independent random streams: 0 recruits and Phase II, 1 Phase III."""
        return np.random.SeedSequence(self.seed, spawn_key=(*self.setting.words(), int(self.cohort), int(stream)))


def code_version():
    """Hash of the modules a simulated cohort depends on and of the numeric libraries' versions."""
    import scipy

    from .. import __version__
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256(f"{__version__} numpy {np.__version__} scipy {scipy.__version__} pandas {pd.__version__}".encode())
    files = sorted({p for pattern in _SOURCES for p in root.glob(pattern)} - {root / p for p in _NOT_SOURCES})
    for path in files:
        h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes())
    return h.hexdigest()[:20]


def recruit(library, kind, noise_scale, rng):
    """One SIMULATED recruit of ``kind`` (:func:`mutual.study.cohort.simulated_recruits`), with the
    judgement noise range ``SIGMA_RANGE`` multiplied by ``noise_scale``."""
    sigma_range = tuple(noise_scale * v for v in _cohort.SIGMA_RANGE)
    people, sups = _cohort.simulated_recruits(library, (kind,), seed=int(rng.integers(2 ** 63)), sigma_range=sigma_range)
    row = people.iloc[0]
    return sups[0], {"kind": kind, "w_max": float(row["w_max"]), "mu": float(row["mu"]), "sigma": float(row["sigma"])}


def _phase2(library, standard, sup, n_scenes, rng):
    """Phase II and the fit of :func:`mutual.study.cohort.simulate_study`; (fit or None, facts)."""
    table = _cohort.phase2_interventions(sup, n_scenes, rng)
    states = table[["x", "y", "theta"]].to_numpy()
    try:
        with warnings.catch_warnings():  # fits at the library's edge are common with noisy recruits: the
            warnings.simplefilter("ignore", LibraryEdgeWarning)  # table records every w_max_hat instead
            fit = fit_supervisor(library, states, prior="mle")
    except ValueError as err:  # too few interventions, or zero variance: nothing to fit
        return None, {"n_interventions": len(states), "excluded": True, "reason": f"no fit: {err}"[:80]}
    excluded = not unsafe_set_contains(fit.value_fn, standard, level=fit.mu)
    return fit, {"n_interventions": len(states), "w_max_hat": fit.w_max, "mu_hat": fit.mu, "excluded": excluded,
                 "reason": "Learned unsafe set misses the Standard one" if excluded else ""}


def simulate_cohort(task, library, conservative, max_recruits_per_analysed=20):
    """SIMULATE one cohort (module docstring): one row per recruit, in recruitment order, with the
    generating parameters, the fit, ``excluded``, and for analysed recruits ``fp_<treatment>``, the
    mean false positives per trial with each safe set (NaN for excluded recruits)."""
    if not isinstance(task, CohortTask):
        raise ValueError(f"task must be a CohortTask, got {type(task).__name__}")
    if not isinstance(library, ValueLibrary) or not isinstance(conservative, ValueFunction):
        raise ValueError("library must be a ValueLibrary and conservative a ValueFunction "
                         "(mutual.study.cohort.study_value_functions)")
    if library.grid_spec != conservative.grid_spec:
        raise ValueError("conservative must share the library's grid")
    s = task.setting
    standard = library[library.index_of(TRUE_W_MAX)]
    kinds = [k for k, _ in MIXES[s.mix]]
    weights = np.array([w for _, w in MIXES[s.mix]], dtype=float)
    rng = np.random.default_rng(task.seed_sequence(0))
    rows, fits, sups = [], [], []
    while sum(not r["excluded"] for r in rows) < task.n_max:
        if len(rows) >= max_recruits_per_analysed * task.n_max:
            raise ValueError(f"{s.label}: {len(rows)} recruits gave fewer than {task.n_max} analysed participants")
        sup, facts = recruit(library, kinds[rng.choice(len(kinds), p=weights / weights.sum())], s.noise_scale, rng)
        fit, more = _phase2(library, standard, sup, s.n_scenes, rng)
        rows.append({"cohort": task.cohort, "recruit": len(rows), **facts, **more})
        fits.append(fit)
        sups.append(sup)
    people = pd.DataFrame(rows)
    design = study_design(len(people), DESIGN_SEED)
    design = design[design["participant"].isin(people.loc[~people["excluded"], "recruit"] + 1)]
    team_of = {"Standard": lambda j: Team(standard, 0.0), "Conservative": lambda j: Team(conservative, 0.0),
               "Learned": lambda j: Team(fits[j].value_fn, fits[j].mu)}
    recruits = (design["participant"] - 1).to_numpy()
    counts = simulate_teaming([team_of[t](j) for j, t in zip(recruits, design["treatment"])],
                              [sups[j] for j in recruits], design["task_version"].tolist(),
                              TeamingConfig(duration=s.trial_seconds), seed=task.seed_sequence(1))
    fp = (pd.DataFrame({"recruit": recruits, "treatment": design["treatment"].to_numpy(),
                        "fp": counts["false_positives"].to_numpy(dtype=float)})
          .groupby(["recruit", "treatment"])["fp"].mean().unstack()[list(TREATMENTS)])
    fp.columns = list(FP_COLUMNS)
    return people.join(fp, on="recruit")
