"""Live views of the SIMULATED chapter 5 study for the notebook's Explore section.

Each view is a plain function returning a :class:`matplotlib.figure.Figure` (built without
pyplot, so nothing is shown twice); the notebook wraps them in ipywidgets. They use the quick
grid's value functions (loaded once per process from the disk cache) and small simulations, so
each answers in about a second on 2 cores.
"""

import functools

import numpy as np
from matplotlib.figure import Figure
from scipy import stats as sps

from ..inputs import check_number
from ..style import PALETTE
from ..supervision import NoisySupervisor
from .cohort import simulate_study, study_value_functions
from .design import TREATMENTS
from .misalignment import straight_approach_starts, supervised_approaches
from .plots import plot_condition_means, plot_misalignment
from .stats import rm_anova, tukey_rm
from .teaming import TeamingConfig

COLORS = {"Standard": PALETTE["vermillion"], "Learned": PALETTE["blue"], "Conservative": PALETTE["green"]}


@functools.lru_cache(maxsize=2)
def _value_functions(quick=True):
    return study_value_functions(quick=quick)


def _cohort_kinds(n_standard, n_conservative, n_gradual, n_agile):
    counts = {kind: check_number(name, value, 0, 50, integer=True) for kind, name, value in (
        ("standard-like", "n_standard", n_standard), ("conservative-like", "n_conservative", n_conservative),
        ("gradual", "n_gradual", n_gradual), ("agile", "n_agile", n_agile))}
    kinds = tuple(k for k, c in counts.items() for _ in range(c))
    if len(kinds) < 2:
        raise ValueError(f"the cohort needs at least 2 recruits, got {len(kinds)}")
    return kinds


def false_positive_rates(study):
    """Per analysed participant and safe set: false positives per detected robot-obstacle encounter
    (a wide participant x treatment table)."""
    s = study.summary
    rate = s["false_positives"] / s["detected_encounters"].where(s["detected_encounters"] > 0)
    table = s.assign(rate=rate).groupby(["participant", "treatment"])["rate"].mean().unstack()
    return table.reindex(columns=list(TREATMENTS))


def cohort_view(n_standard=3, n_conservative=3, n_gradual=5, n_agile=1, noise=0.055, trial_seconds=15.0,
                n_scenes=40, seed=0):
    """A SIMULATED study of a cohort of the given mix (recruit kinds of
    :func:`mutual.study.cohort.simulated_recruits`) whose judgement noise is ``noise`` (sigma,
    value units): Phase II fits, Phase III trials of ``trial_seconds``, then the repeated-measures
    ANOVA of false positives per trial (left, mean +- SE and each participant) and the false-positive
    rate per detected encounter (right, mean with 95% CI over participants)."""
    kinds = _cohort_kinds(n_standard, n_conservative, n_gradual, n_agile)
    noise = check_number("noise", noise, 0.0, 1.0)
    trial_seconds = check_number("trial_seconds", trial_seconds, 1.0, 600.0)
    library, conservative = _value_functions(True)
    fig = Figure(figsize=(9.5, 3.8), layout="constrained")
    left, right = fig.subplots(1, 2)
    try:
        study = simulate_study(library, conservative, n_scenes=check_number("n_scenes", n_scenes, 2, 400, integer=True),
                               config=TeamingConfig(duration=trial_seconds), seed=seed, kinds=kinds,
                               sigma_range=(noise, noise))
        fp = study.trials[study.trials["measure"] == "false_positives"]
        anova = rm_anova(fp, "value", "treatment", "participant", aggregate="mean", levels=TREATMENTS)
    except ValueError as err:      # too few analysed recruits, degenerate data: say so in the figure
        left.text(0.5, 0.5, "\n".join(_wrap(str(err), 60)), ha="center", va="center", fontsize=8,
                  transform=left.transAxes)
        left.set_axis_off()
        right.set_axis_off()
        fig.suptitle(f"SIMULATED cohort of {len(kinds)} recruits: no analysis possible")
        return fig
    plot_condition_means(left, anova, tukey_rm(anova), colors=[COLORS[t] for t in TREATMENTS])
    left.set_xlabel("robot team's safe set")
    left.set_ylabel("false positives per trial (mean ± SE)")
    left.set_title(f"F({anova.df1}, {anova.df2}) = {anova.F:.2f}, p = {anova.p:.2g}, "
                   f"GG p = {anova.p_gg:.2g}", fontsize=9)
    rates = false_positive_rates(study).dropna()
    mean, n = rates.mean(), len(rates)
    half = sps.t.ppf(0.975, n - 1) * rates.std(ddof=1) / np.sqrt(n) if n > 1 else np.zeros(len(TREATMENTS))
    x = np.arange(len(TREATMENTS))
    right.bar(x, mean, yerr=half, capsize=4, color=[COLORS[t] for t in TREATMENTS], alpha=0.85)
    right.set_xticks(x, list(TREATMENTS))
    right.set_ylim(0, 1)
    right.set_xlabel("robot team's safe set")
    right.set_ylabel("false positives per detected encounter\n(mean, 95% CI over participants)")
    right.set_title("supervisor false-positive rate", fontsize=9)
    people = study.participants
    fig.suptitle(f"SIMULATED cohort: {len(people)} recruits, {int((~people['excluded']).sum())} analysed, "
                 f"noise sigma = {noise:g}, {trial_seconds:g} s trials")
    return fig


def _wrap(text, width):
    words, lines, line = text.split(), [], ""
    for word in words:
        if line and len(line) + len(word) + 1 > width:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}".strip()
    return lines + [line]


def misalignment_view(w_supervisor=0.5, mu=0.3, noise=0.05, k=0.0, n_robots=40, seed=0):
    """Fig. 5.1 live: robots that detected the obstacle, ignoring (the Standard set) or following
    (the supervisor's own set at ``alpha = mu + k sigma``, Sec. 4.5) the safe set of a noisy
    supervisor with internal turn rate ``w_supervisor`` (a library member), margin ``mu`` and noise
    ``noise``; crosses mark the supervisor's (false-positive) interventions. SIMULATED."""
    library, _ = _value_functions(True)
    if w_supervisor not in set(library.w_maxes.tolist()):
        raise ValueError(f"w_supervisor must be one of the library's turn rates {library.w_maxes.tolist()}, "
                         f"got {w_supervisor!r}")
    mu = check_number("mu", mu, 0.0, 3.0)
    noise = check_number("noise", noise, 0.0, 1.0)
    k = check_number("k", k, -3.0, 5.0)
    supervisor = NoisySupervisor(library[library.index_of(w_supervisor)], mu, noise)
    starts = straight_approach_starts(check_number("n_robots", n_robots, 1, 400, integer=True), np.random.default_rng(seed))
    fig = Figure(figsize=(9.5, 3.6), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    teams = [("ignoring: Standard set, alpha = 0", library[library.index_of(1.0)], 0.0),
             (f"following: supervisor's set, alpha = mu + {k:g} sigma", supervisor.value_fn, mu + k * noise)]
    for ax, (title, value, alpha), colour in zip(axes, teams, (COLORS["Standard"], COLORS["Learned"])):
        result = supervised_approaches(value, alpha, supervisor, starts, np.random.default_rng(seed + 1))
        plot_misalignment(ax, result, supervisor, title=title, color=colour)
        ax.set_xlim(-7.5, 5)
        ax.set_ylim(-5, 4)
        ax.legend(fontsize=6, loc="lower left")
    axes[1].set_ylabel("")
    fig.suptitle(f"SIMULATED supervisor (w_max = {w_supervisor:g}, mu = {mu:g}, sigma = {noise:g})", fontsize=10)
    return fig
