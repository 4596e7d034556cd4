"""Thrust 1, chapter 5: the user study of learned safe sets in human-robot teams.

The counterbalanced design (:mod:`.design`), the tidy study tables and their loaders
(:mod:`.data`), the subject x level table of any long data set (:mod:`.cells`), the repeated-measures
statistics in a study's own words (:mod:`.stats`:
``rm_anova(data, dv, within, subject)``, ``tukey_rm``, ``paired_t_holm``), the thesis's
statistics re-derived from its published numbers (:mod:`.published`), and the SIMULATED study:
the teaming task (:mod:`.teaming`), whole cohorts of simulated supervisors (:mod:`.cohort`), the
misaligned-expectations illustration (:mod:`.misalignment`), figures (:mod:`.plots`) and the
notebook's live views (:mod:`.explore`).

The statistics and the tables import no JAX: ``import mutual.study`` stays light. The simulation's
names (``Study``, ``simulate_study``, ``Team``, ...), which need chapter 4's value functions, the power
of a replication (:mod:`.power`, :mod:`.cohort_power`, :mod:`.sweep`) and the figures are imported on
first use.
"""

from ..lazy import lazy_names
from .data import read_table, write_table
from .design import design_balance, study_design
from .stats import DegenerateDataError, RMAnova, paired_t_holm, pairwise_comparisons, rm_anova, tukey_rm

_ON_FIRST_USE = {
    # the simulated study (it loads JAX through chapter 4's value functions)
    "Study": "cohort", "simulate_study": "cohort", "write_simulated_study": "cohort", "study_value_functions": "cohort",
    "avoidance_onset": "cohort", "learned_set_cluster": "cohort", "predicted_and_observed": "cohort",
    "Team": "teaming", "TeamingConfig": "teaming", "simulate_teaming": "teaming",
    # the thesis's statistics re-derived from its published numbers
    "design_from_f_dofs": "published", "f_p_value": "published", "recover_from_summary": "published",
    "table_5_1_ratios": "published", "arcs_against_clusters": "published",
    "prediction_agreement": "published",
    # power of a replication: analytic, then simulated cohorts on Dask
    "contrast_sample_size": "power", "dz_from_summary": "power", "effect_size_from_f": "power",
    "gpower_table": "power", "noncentrality_interval": "power", "replication_plan": "power",
    "CohortSetting": "cohort_power", "CohortTask": "cohort_power", "code_version": "cohort_power",
    "simulate_cohort": "cohort_power", "TaskCache": "sweep", "run_tasks": "sweep",
    "implied_effect": "power_summary", "power_table": "power_summary", "recommendations": "power_summary",
    # figures (matplotlib)
    "plot_condition_means": "plots", "MAX_SUBJECT_LINES": "plots", "finish_power_axes": "power_plots", "plot_simulated_power": "power_plots",
}

__all__ = ["CohortSetting", "CohortTask", "DegenerateDataError", "MAX_SUBJECT_LINES", "RMAnova", "Study", "TaskCache", "Team",
           "TeamingConfig", "arcs_against_clusters", "avoidance_onset", "code_version", "contrast_sample_size",
           "design_balance", "design_from_f_dofs", "dz_from_summary", "effect_size_from_f", "f_p_value",
           "finish_power_axes", "gpower_table", "implied_effect", "learned_set_cluster", "noncentrality_interval",
           "paired_t_holm", "pairwise_comparisons", "plot_condition_means", "plot_simulated_power", "power_table",
           "predicted_and_observed", "prediction_agreement", "read_table", "recommendations", "recover_from_summary",
           "replication_plan", "rm_anova", "run_tasks", "simulate_cohort", "simulate_study", "simulate_teaming",
           "study_design", "study_value_functions", "table_5_1_ratios", "tukey_rm", "write_simulated_study",
           "write_table"]

__getattr__ = lazy_names(__name__, _ON_FIRST_USE)
