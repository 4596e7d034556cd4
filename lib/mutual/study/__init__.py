"""Thrust 1, chapter 5: the user study of learned safe sets in human-robot teams.

The counterbalanced design (:mod:`.design`), the tidy study tables (:mod:`.data`), the
repeated-measures statistics (:mod:`.stats`), and the SIMULATED study: the teaming task
(:mod:`.teaming`) and whole cohorts of simulated supervisors (:mod:`.cohort`).
"""

from .cohort import Study, simulate_study
from .data import read_table, write_table
from .design import study_design
from .stats import RMAnova, paired_t_holm, rm_anova, tukey_rm
from .teaming import Team, TeamingConfig, simulate_teaming

__all__ = ["RMAnova", "Study", "Team", "TeamingConfig", "paired_t_holm", "read_table", "rm_anova", "simulate_study",
           "simulate_teaming", "study_design", "tukey_rm", "write_table"]
