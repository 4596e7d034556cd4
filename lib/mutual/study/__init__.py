"""Thrust 1, chapter 5: the user study of learned safe sets in human-robot teams.

The counterbalanced design (:mod:`.design`), the tidy study tables and their loaders
(:mod:`.data`), the subject x level table of any long data set (:mod:`.cells`), the repeated-measures
statistics in a study's own words (:mod:`.stats`:
``rm_anova(data, dv, within, subject)``, ``tukey_rm``, ``paired_t_holm``), the thesis's
statistics re-derived from its published numbers (:mod:`.published`), and the SIMULATED study:
the teaming task (:mod:`.teaming`), whole cohorts of simulated supervisors (:mod:`.cohort`), the
misaligned-expectations illustration (:mod:`.misalignment`), figures (:mod:`.plots`) and the
notebook's live views (:mod:`.explore`).

The statistics and the tables import no JAX: ``import mutual.study`` stays light (issue 23), and
the simulation's names (``Study``, ``simulate_study``, ``Team``, ...), which need chapter 4's value
functions, are imported on first use.
"""

from .data import read_table, write_table
from .design import study_design
from .stats import DegenerateDataError, RMAnova, paired_t_holm, pairwise_comparisons, rm_anova, tukey_rm

__all__ = ["DegenerateDataError", "RMAnova", "Study", "Team", "TeamingConfig", "paired_t_holm", "pairwise_comparisons",
           "read_table", "rm_anova", "simulate_study", "simulate_teaming", "study_design", "tukey_rm",
           "write_simulated_study", "write_table"]

_SIMULATION = {"Study": "cohort", "simulate_study": "cohort", "write_simulated_study": "cohort",
               "Team": "teaming", "TeamingConfig": "teaming", "simulate_teaming": "teaming"}


def __getattr__(name):
    """The simulation's names, imported when first used (they load JAX through chapter 4)."""
    if name not in _SIMULATION:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    if _SIMULATION[name] == "cohort":
        from . import cohort as module
    else:
        from . import teaming as module
    value = getattr(module, name)
    globals()[name] = value
    return value
