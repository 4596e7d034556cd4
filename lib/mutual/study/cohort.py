"""A SIMULATED chapter 5 study (Sec. 5.2): recruits, their Phase II interventions and fitted
safe sets (chapter 4's estimator), and the Phase III teaming trials of the whole design.

Phase II (supervisor data): each simulated participant is a noisy idealized supervisor
(Sec. 4.3) with an internal Dubins model ``w_max``, a margin ``mu`` and a noise ``sigma``.
They watch robots drive straight at an obstacle and intervene at the first state with
``V_S(x) + w <= mu``, ``w ~ N(0, sigma^2)`` drawn once per judgement (per scene). The
Learned safe set is fitted to the intervention states with the chapter 4 estimator
(eqs. 4.8-4.12) and used at ``alpha = mu_hat`` (Sec. 5.2.2). Participants whose Learned
unsafe set does not contain the Standard unsafe set are excluded (Sec. 5.2.1).
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..atomic import atomic_path
from ..supervision import (FULL_GRID, QUICK_GRID, SPEED, TRUE_W_MAX, NoisySupervisor, ValueFunction, ValueLibrary,
                           approach_scenes, avoid_value_function, check_states, fit_supervisor, unsafe_set_contains,
                           validate_interventions, value_library)
from .data import OBJECTIVE_MEASURES, TRIAL_COLUMNS, illustrative_questionnaire, validate_trials, write_table
from .design import DESIGN_COLUMNS, TREATMENTS, study_design
from .teaming import OBSTACLE_RADIUS, Team, TeamingConfig, TeamingRecord, simulate_teaming


# the supervisor library of Fig. 4.2 (w_max between 0 and 3, Sec. 5.2.1); 1.0 is the true robot
STUDY_W_MAXES = (0.375, 0.5, 0.625, 0.75, 1.0, 1.5, 2.0, 3.0)


# twelve recruits spread as Fig. 5.5 describes (3 / 3 / 5 analysed) plus one who overestimates agility
RECRUIT_KINDS = ("standard-like",) * 3 + ("conservative-like",) * 3 + ("gradual",) * 5 + ("agile",)


SIGMA_RANGE = (0.03, 0.08)
_KIND_SPEC = {"standard-like": ((1.0,), (0.1, 0.35)), "conservative-like": ((1.0,), (0.85, 1.15)),
              "gradual": ((0.375, 0.5, 0.625), (0.2, 0.6)), "agile": ((2.0,), (0.0, 0.1))}
RECRUIT_KIND_NAMES = tuple(_KIND_SPEC)


def _check_kinds(kinds):
    if isinstance(kinds, str) or not isinstance(kinds, (list, tuple)) or len(kinds) == 0:
        raise ValueError(f"kinds must be a non-empty list of participant kinds, got {kinds!r}")
    unknown = sorted({str(k) for k in kinds if k not in _KIND_SPEC})
    if unknown:
        raise ValueError(f"unknown participant kind(s) {unknown}; expected some of {list(_KIND_SPEC)}")
    return tuple(kinds)


def _check_sigma_range(sigma_range):
    try:
        lo, hi = (float(v) for v in sigma_range)
    except (TypeError, ValueError):
        raise ValueError(f"sigma_range must be two numbers (low, high), got {sigma_range!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 <= lo <= hi):
        raise ValueError(f"sigma_range must satisfy 0 <= low <= high (finite), got {sigma_range!r}")
    return lo, hi


def simulated_recruits(library, kinds=RECRUIT_KINDS, seed=0, sigma_range=SIGMA_RANGE):
    """SIMULATED participants: one :class:`NoisySupervisor` per entry of ``kinds`` (Fig. 5.5 spread).

    ``standard-like``: ``w_max = 1``, ``mu ~ U(0.1, 0.35)``; ``conservative-like``: ``w_max = 1``,
    ``mu ~ U(0.85, 1.15)`` (about the Conservative set, whose doubled obstacle is ``V >= r``);
    ``gradual``: ``w_max`` one of 0.375 / 0.5 / 0.625 (turns earlier, gentler arcs), ``mu ~ U(0.2, 0.6)``;
    ``agile``: ``w_max = 2`` (overestimates agility), ``mu ~ U(0, 0.1)``. Judgement noise
    ``sigma ~ U(sigma_range)``, by default ``U(0.03, 0.08)`` (small: with larger noise the estimator of
    eq. 4.12 drifts to the flattest library member). All ``w_max`` must be library members.
    Returns (DataFrame of the parameters, list of supervisors).
    """
    if not isinstance(library, ValueLibrary):
        raise ValueError(f"library must be a mutual.supervision.reachability.ValueLibrary, got {type(library).__name__}")
    kinds = _check_kinds(kinds)
    s_lo, s_hi = _check_sigma_range(sigma_range)
    rng = np.random.default_rng(seed)
    rows, sups = [], []
    for i, kind in enumerate(kinds):
        choices, (lo, hi) = _KIND_SPEC[kind]
        w = float(rng.choice(choices))
        mu, sigma = float(rng.uniform(lo, hi)), float(rng.uniform(s_lo, s_hi))
        sups.append(NoisySupervisor(library[library.index_of(w)], mu, sigma))
        rows.append((f"P{i + 1:02d}", kind, w, mu, sigma))
    return pd.DataFrame(rows, columns=["participant", "kind", "w_max", "mu", "sigma"]), sups


def phase2_interventions(supervisor, n_scenes, rng, start_distance=7.5, dt=0.01):
    """Phase II: where ``supervisor`` intervenes on ``n_scenes`` straight approaches (Sec. 5.2.1).

    Scenes from :func:`mutual.supervision.supervisor.approach_scenes`, one judgement noise per scene
    (:meth:`NoisySupervisor.first_interventions`). Returns an interventions table in the
    :mod:`mutual.supervision.supervisor` CSV schema without the participant column (trial = scene, time =
    seconds into the scene); scenes in which the supervisor never intervenes are absent.
    """
    r = supervisor.value_fn.obstacle_radius
    scenes = approach_scenes(n_scenes, rng, r, start_distance, dt=dt)
    states, idx = supervisor.first_interventions(scenes, rng)
    time = np.hypot(*(states[:, :2] - scenes[idx, 0, :2]).T) / SPEED
    return pd.DataFrame({"trial": idx, "time": time, "x": states[:, 0], "y": states[:, 1], "theta": states[:, 2]})


def estimator_recovery(library, w_maxes, mu, sigmas, n_scenes=40, repeats=10, seed=0):
    """How often the estimator of eq. (4.12) recovers a simulated supervisor's ``w_max``.

    For each true ``w_max`` (a library member) and judgement noise ``sigma``, ``repeats`` simulated
    Phase II sessions of ``n_scenes`` are fitted (``fit_supervisor``, MLE); returns a DataFrame with
    the share of exact recoveries and the mean fitted ``w_max``.
    """
    if isinstance(repeats, bool) or not isinstance(repeats, (int, np.integer)) or repeats < 1:
        raise ValueError(f"repeats must be a positive integer, got {repeats!r}")
    rng = np.random.default_rng(seed)
    rows = []
    for w in w_maxes:
        for sigma in sigmas:
            sup = NoisySupervisor(library[library.index_of(w)], mu, sigma)
            fits = [fit_supervisor(library, phase2_interventions(sup, n_scenes, rng)[["x", "y", "theta"]].to_numpy(),
                                   values=_same_values(library)).w_max for _ in range(repeats)]
            rows.append({"true w_max": w, "sigma": sigma, "recovered": float(np.mean(np.isclose(fits, w))),
                         "mean fitted w_max": float(np.mean(fits))})
    return pd.DataFrame(rows)


def _same_values(library):
    """Fit on the values the simulated supervisors judge with: exact for an exact library, else the grid's."""
    return "exact" if library.members[0].exact else "grid"


def learned_set_cluster(w_max, mu, gradual_below=0.75, conservative_from=0.5):
    """Fig. 5.5's kinds of Learned set: ``gradual`` when the fitted ``w_max < gradual_below``, else
    ``conservative-like`` when ``mu >= conservative_from`` (half way to the doubled obstacle,
    whose safe set is ``V >= r``), else ``standard-like``."""
    for name, v in (("w_max", w_max), ("mu", mu), ("gradual_below", gradual_below),
                    ("conservative_from", conservative_from)):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.number)) or not np.isfinite(v):
            raise ValueError(f"{name} must be a finite number, got {v!r}")
    if w_max <= 0:
        raise ValueError(f"w_max must be positive, got {w_max!r}")
    if w_max < gradual_below:
        return "gradual"
    return "conservative-like" if mu >= conservative_from else "standard-like"


def fraction_inside(value, states, level=0.0):
    """(fraction, count) of ``states`` inside the safe set ``{V >= level}`` (Table 5.1 left; Fig. 5.6);
    states off the grid count as inside (far from the obstacle)."""
    if not isinstance(value, ValueFunction):
        raise ValueError(f"value must be a mutual.supervision.reachability.ValueFunction, got {type(value).__name__}")
    if isinstance(level, bool) or not isinstance(level, (int, float, np.number)) or not np.isfinite(level):
        raise ValueError(f"level must be a finite number, got {level!r}")
    states = check_states(states)
    if len(states) == 0:
        raise ValueError("states must hold at least one state")
    v = value.interp(states, fill_value=np.inf)
    return float(np.mean(v >= level)), int(np.sum(v >= level))


def avoidance_onset(value, level=0.0, resolution=1601):
    """How far ahead of the obstacle centre a car driving straight at it (theta = 0, y = 0) meets
    ``{V < level}``: where an avoidance arc on that safe set begins. The first sample below
    ``level`` on a line of ``resolution`` points is refined by linear interpolation of V (exact for
    the trilinear V between grid nodes). ValueError if the line never meets the set."""
    if isinstance(level, bool) or not isinstance(level, (int, float, np.number)) or not np.isfinite(level):
        raise ValueError(f"level must be a finite number, got {level!r}")
    w = value.grid_spec.half_width
    xs = np.linspace(-w, 0.0, resolution)
    v = value.interp(np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], axis=1))
    below = np.flatnonzero(v < level)
    if len(below) == 0:
        raise ValueError(f"a car driving straight at the obstacle never meets {{V < {level:g}}} within the grid")
    i = below[0]
    if i == 0:
        return float(-xs[0])
    frac = (v[i - 1] - level) / (v[i - 1] - v[i])
    return float(-(xs[i - 1] + frac * (xs[i] - xs[i - 1])))


def late_intervention_bound(participants, interventions):
    """The noisy idealized supervisor's bound on interventions inside the Standard reachable set (Fig. 5.6):
    a conservative supervisor (eq. 4.4, V_S <= V) intervenes at V_S = mu - w, so an intervention can lie in
    {V < 0} only if w > mu: at most sum_i n_i Phi(-mu_i / sigma_i) over the ``participants`` (columns
    participant, mu, sigma) with their counts in ``interventions``. Returns (expected bound, per-person table)."""
    from scipy import stats

    counts = interventions.groupby("participant").size()
    people = participants.set_index("participant").loc[counts.index]
    share = stats.norm.cdf(-people["mu"] / people["sigma"])
    table = pd.DataFrame({"interventions": counts, "mu / sigma": people["mu"] / people["sigma"],
                          "P(w > mu)": share, "expected inside Standard (at most)": counts * share})
    return float(table["expected inside Standard (at most)"].sum()), table


def study_value_functions(quick=False, progress=False, exact=False):
    """The supervisor library over ``STUDY_W_MAXES`` (obstacle radius 1) and the Conservative value
    function (true dynamics, obstacle radius doubled), on the quick or full grid (disk-cached). With
    ``exact`` both are the closed form evaluated exactly at every state
    (:class:`mutual.supervision.exact.ExactValueFunction`): no HJ solve, no interpolation error."""
    grid = QUICK_GRID if quick else FULL_GRID
    if exact:
        from ..supervision import exact_library, exact_value_function

        return (exact_library(STUDY_W_MAXES, OBSTACLE_RADIUS, grid),
                exact_value_function(TRUE_W_MAX, 2 * OBSTACLE_RADIUS, grid))
    library = value_library(STUDY_W_MAXES, OBSTACLE_RADIUS, grid_spec=grid, progress=progress)
    conservative = avoid_value_function(TRUE_W_MAX, 2 * OBSTACLE_RADIUS, grid_spec=grid, progress=progress)
    return library, conservative


@dataclass(repr=False)
class Study:
    """A SIMULATED study: ``participants`` (generating parameters, fit, exclusion), Phase II
    ``interventions`` (supervisor CSV schema), Phase III ``trials`` (tidy schema of
    :mod:`mutual.study.data`), the ``design``, per-participant ``fits`` and ``supervisors``,
    the Standard and Conservative value functions, the wide per-trial ``summary`` (with the
    encounter counts) and a ``record`` of one trial (Fig. 5.3)."""
    participants: pd.DataFrame
    interventions: pd.DataFrame
    trials: pd.DataFrame
    summary: pd.DataFrame
    design: pd.DataFrame
    fits: dict
    supervisors: dict
    standard: ValueFunction
    conservative: ValueFunction
    record: TeamingRecord
    simulated: bool = True

    def __repr__(self):
        people = self.participants
        excluded = int(people["excluded"].sum()) if "excluded" in people else 0
        n_trials = self.trials.drop_duplicates(["participant", "trial"]).shape[0]
        label = "SIMULATED " if self.simulated else ""
        return (f"Study({label}{len(people)} recruits, {len(people) - excluded} analysed, {excluded} excluded; "
                f"{len(self.interventions)} Phase II interventions; {n_trials} Phase III trials of "
                f"{', '.join(sorted(self.trials['treatment'].unique()))}; "
                f"measures {', '.join(self.trials['measure'].unique())})")


def simulate_study(library, conservative, n_scenes=40, config=TeamingConfig(), seed=0, kinds=RECRUIT_KINDS,
                   sigma_range=SIGMA_RANGE):
    """Simulate Phase II and Phase III for recruits of ``kinds`` (Sec. 5.2), all trials in one batch.

    Phase II: ``n_scenes`` approaches per recruit; the Learned set is the MLE fit (eq. 4.12,
    ``alpha = mu*``); recruits whose Learned unsafe set ``{V < mu*}`` does not contain the Standard one
    (:func:`mutual.supervision.reachability.unsafe_set_contains` at ``level = mu*``) are excluded. Phase III:
    the design of :func:`mutual.study.design.study_design` for all recruits, run for those
    who remain (Standard: ``w_max = 1``, ``alpha = 0``; Learned: the fit; Conservative:
    obstacle doubled, ``alpha = 0``); the supervisor is the recruit's own noisy model.
    ``sigma_range``: the recruits' judgement noise (:func:`simulated_recruits`).
    Cost: about 0.5 s for the 12 recruits of the thesis with 20 s trials on 2 cores.
    """
    if not isinstance(library, ValueLibrary):
        raise ValueError(f"library must be a mutual.supervision.reachability.ValueLibrary, got {type(library).__name__}")
    if not isinstance(conservative, ValueFunction):
        raise ValueError(f"conservative must be a ValueFunction, got {type(conservative).__name__}")
    if isinstance(n_scenes, bool) or not isinstance(n_scenes, (int, np.integer)) or n_scenes < 2:
        raise ValueError(f"n_scenes must be an integer >= 2 (Phase II scenes per recruit), got {n_scenes!r}")
    if not isinstance(config, TeamingConfig):
        raise ValueError(f"config must be a TeamingConfig, got {type(config).__name__}")
    standard = library[library.index_of(TRUE_W_MAX)]
    if conservative.grid_spec != standard.grid_spec:
        raise ValueError("conservative must share the library's grid")
    rng = np.random.default_rng(seed)
    people, sups = simulated_recruits(library, kinds, seed, sigma_range)
    tables, fits, extra = [], {}, []
    for pid, sup in zip(people["participant"], sups):
        table = phase2_interventions(sup, n_scenes, rng).assign(participant=pid)
        states = table[["x", "y", "theta"]].to_numpy()
        try:
            fit = fit_supervisor(library, states, prior="mle", values=_same_values(library))
        except ValueError as err:
            raise ValueError(f"simulated recruit {pid} ({len(states)} interventions in {n_scenes} scenes) cannot "
                             f"be fitted: {err}") from None
        fits[pid] = fit
        extra.append((len(table), fit.w_max, fit.mu, fit.sigma,
                      not unsafe_set_contains(fit.value_fn, standard, level=fit.mu)))
        tables.append(table)
    people[["n_interventions", "w_max_hat", "mu_hat", "sigma_hat", "excluded"]] = pd.DataFrame(extra)
    interventions = validate_interventions(pd.concat(tables, ignore_index=True)[
        ["participant", "trial", "time", "x", "y", "theta"]])
    design = study_design(len(kinds), seed)
    design["participant"] = design["participant"].map(lambda i: f"P{i:02d}")
    keep = design[design["participant"].isin(people.loc[~people["excluded"], "participant"])].reset_index(drop=True)
    if len(keep) == 0:
        raise ValueError(f"all {len(people)} simulated recruits were excluded (no Learned set contains the Standard "
                         "unsafe set); there is no study to run")
    by_pid = dict(zip(people["participant"], sups))
    team_of = {"Standard": lambda pid: Team(standard, 0.0), "Conservative": lambda pid: Team(conservative, 0.0),
               "Learned": lambda pid: Team(fits[pid].value_fn, fits[pid].mu)}
    teams = [team_of[t](pid) for pid, t in zip(keep["participant"], keep["treatment"])]
    counts, record = simulate_teaming(teams, [by_pid[p] for p in keep["participant"]],
                                      keep["task_version"].tolist(), config, seed, record=0)
    wide = pd.concat([keep, counts], axis=1)
    trials = wide.melt(id_vars=[c for c in keep.columns], value_vars=list(OBJECTIVE_MEASURES), var_name="measure")
    trials = validate_trials(trials[TRIAL_COLUMNS].sort_values(["participant", "trial"], kind="stable"))
    return Study(people, interventions, trials.reset_index(drop=True), wide, design, fits, by_pid, standard,
                 conservative, record)


def predicted_and_observed(study):
    """Table 5.1 from a study: Phase II interventions inside each safe set (the model's predicted
    false positives relative to Standard) and Phase III average false positives per trial (observed
    relative to Standard), over the analysed participants."""
    if not isinstance(study, Study):
        raise ValueError(f"study must be a Study, got {type(study).__name__}")
    people = study.participants[~study.participants["excluded"]]
    iv = study.interventions[study.interventions["participant"].isin(people["participant"])]
    states = iv[["x", "y", "theta"]].to_numpy()
    learned = np.zeros(len(iv), bool)
    for pid, idx in iv.groupby("participant").indices.items():
        learned[idx] = study.fits[pid].value_fn.interp(states[idx], fill_value=np.inf) >= study.fits[pid].mu
    inside = {"Standard": study.standard.interp(states, fill_value=np.inf) >= 0,
              "Conservative": study.conservative.interp(states, fill_value=np.inf) >= 0, "Learned": learned}
    fp = study.trials[study.trials["measure"] == "false_positives"]
    per_person = fp.groupby(["participant", "treatment"])["value"].mean().unstack()
    rows = []
    for t in TREATMENTS:
        rows.append({"safe set": t, "interventions in safe set": int(inside[t].sum()), "interventions": len(states),
                     "predicted F.P. vs Std.": inside[t].sum() / inside["Standard"].sum(),
                     "average F.P.": float(per_person[t].mean()),
                     "observed F.P. vs Std.": float(per_person[t].mean() / per_person["Standard"].mean())})
    return pd.DataFrame(rows)


def write_simulated_study(study, folder):
    """Write a simulated ``study``'s tables into ``folder``: ``ch5_simulated_phase3.csv`` (trials),
    ``ch5_simulated_phase2_interventions.csv``, ``ch5_simulated_participants.csv`` and the
    ILLUSTRATIVE ``ch5_illustrative_questionnaire.csv`` (seed 0); each file atomically. The notebook
    passes :func:`mutual.compendium.paths.generated_data_dir` (``data/`` only under ``make figures``)."""
    if not isinstance(study, Study) or not study.simulated:
        raise ValueError("study must be a simulated Study (these files are named and documented as simulated)")
    if not isinstance(folder, (str, Path)):
        raise ValueError(f"folder must be a path, got {type(folder).__name__}")
    folder = Path(folder)
    write_table(study.trials, folder / "ch5_simulated_phase3.csv", "trials")
    # the simulated states to 6 significant digits: their last bits follow the CPU's sin/cos, and the committed
    # bytes must not; the counts and answers of the trial tables are written exactly
    write_table(study.interventions, folder / "ch5_simulated_phase2_interventions.csv", "interventions", digits=6)
    analysed = study.trials.drop_duplicates(["participant", "trial"])[DESIGN_COLUMNS].reset_index(drop=True)
    write_table(illustrative_questionnaire(analysed, seed=0), folder / "ch5_illustrative_questionnaire.csv", "trials")
    with atomic_path(folder / "ch5_simulated_participants.csv") as tmp:
        study.participants.to_csv(tmp, index=False, float_format="%.6g")
    return folder
