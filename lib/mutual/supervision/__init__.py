"""Thrust 1, chapter 4: learning a supervisor's safe set from their interventions.

HJI avoid sets of the Dubins car (:mod:`.dubins`, :mod:`.reachability`, eq. 4.3; grids and value
functions in :mod:`.value_function`, the verified disk cache in :mod:`.value_cache`), the noisy
idealized supervisor (:mod:`.supervisor`, Sec. 4.3), the maximum-likelihood fit of their safe set
(:mod:`.fit`, eqs. 4.8-4.12), control on a learned safe set (:mod:`.control`, Sec. 4.5), and
interactive views for the notebook's Explore section (:mod:`.explore`).
"""

from .control import binomial_consistent, false_positive_rates, filter_control, safety_controller, simulate_filtered
from .dubins import (SPEED, TRUE_W_MAX, avoid_value_closed_form, check_states, closed_form_dtheta, closed_form_values,
                     dubins_arc, dubins_step, keep_out_margin, rotate_to_heading, unsafe_reach, wrap_angle)
from .exact import exact_library, exact_value_function
from .fit import (LibraryEdgeWarning, SupervisorFit, data_efficiency_scan, expected_coverage, fit_supervisor,
                  numerical_gaussian_fit, recovery_summary)
from .reachability import avoid_value_function, closed_form_agreement, value_drift, value_library
from .supervisor import (OPTIONAL_COLUMNS, REQUIRED_COLUMNS, NoisySupervisor, approach_scenes, check_inside,
                         collect_interventions, intervention_states, read_interventions, validate_interventions,
                         write_interventions)
from .value_cache import CacheWarning
from .value_function import FULL_GRID, QUICK_GRID, GridSpec, ValueFunction, ValueLibrary, unsafe_set_contains

__all__ = ["FULL_GRID", "OPTIONAL_COLUMNS", "QUICK_GRID", "REQUIRED_COLUMNS", "SPEED", "TRUE_W_MAX", "CacheWarning",
           "GridSpec", "LibraryEdgeWarning", "NoisySupervisor", "SupervisorFit", "ValueFunction", "ValueLibrary",
           "approach_scenes", "avoid_value_closed_form", "avoid_value_function", "binomial_consistent", "check_inside",
           "check_states", "closed_form_agreement", "closed_form_dtheta", "closed_form_values", "collect_interventions",
           "data_efficiency_scan", "dubins_arc", "dubins_step", "exact_library", "exact_value_function",
           "expected_coverage", "false_positive_rates", "filter_control", "fit_supervisor", "intervention_states",
           "keep_out_margin", "numerical_gaussian_fit", "read_interventions", "recovery_summary", "rotate_to_heading",
           "safety_controller", "simulate_filtered", "unsafe_reach", "unsafe_set_contains", "validate_interventions",
           "value_drift", "value_library", "wrap_angle", "write_interventions"]
