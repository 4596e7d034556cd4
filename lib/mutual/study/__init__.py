"""Thrust 1, chapter 5: the user study of learned safe sets in human-robot teams.

The counterbalanced design (:mod:`.design`), the tidy study tables and their loaders
(:mod:`.data`), the repeated-measures statistics in a study's own words (:mod:`.stats`:
``rm_anova(data, dv, within, subject)``, ``tukey_rm``, ``paired_t_holm``), the thesis's
statistics re-derived from its published numbers (:mod:`.published`), and the SIMULATED study:
the teaming task (:mod:`.teaming`), whole cohorts of simulated supervisors (:mod:`.cohort`), the
misaligned-expectations illustration (:mod:`.misalignment`), figures (:mod:`.plots`) and the
notebook's live views (:mod:`.explore`).
"""

from .cohort import Study, simulate_study, write_simulated_study
from .data import read_table, write_table
from .design import study_design
from .stats import DegenerateDataError, RMAnova, paired_t_holm, pairwise_comparisons, rm_anova, tukey_rm
from .teaming import Team, TeamingConfig, simulate_teaming

__all__ = ["DegenerateDataError", "RMAnova", "Study", "Team", "TeamingConfig", "paired_t_holm", "pairwise_comparisons",
           "read_table", "rm_anova", "simulate_study", "simulate_teaming", "study_design", "tukey_rm",
           "write_simulated_study", "write_table"]
