"""Thrust 1, chapter 4: learning a supervisor's safe set from their interventions.

HJI avoid sets of the Dubins car (:mod:`.dubins`, :mod:`.reachability`, eq. 4.3; grids and value
functions in :mod:`.value_function`, the verified disk cache in :mod:`.value_cache`), the noisy
idealized supervisor (:mod:`.supervisor`, Sec. 4.3), the maximum-likelihood fit of their safe set
(:mod:`.fit`, eqs. 4.8-4.12), control on a learned safe set (:mod:`.control`, Sec. 4.5), and
interactive views for the notebook's Explore section (:mod:`.explore`).
"""

from .control import false_positive_rates, filter_control, safety_controller
from .fit import LibraryEdgeWarning, SupervisorFit, fit_supervisor
from .reachability import avoid_value_function, value_library
from .supervisor import NoisySupervisor, approach_scenes, collect_interventions, read_interventions, write_interventions
from .value_cache import CacheWarning
from .value_function import FULL_GRID, QUICK_GRID, GridSpec, ValueFunction, ValueLibrary, unsafe_set_contains

__all__ = ["CacheWarning", "FULL_GRID", "GridSpec", "LibraryEdgeWarning", "NoisySupervisor", "QUICK_GRID",
           "SupervisorFit", "ValueFunction", "ValueLibrary", "approach_scenes", "avoid_value_function",
           "collect_interventions", "false_positive_rates", "filter_control", "fit_supervisor", "read_interventions",
           "safety_controller", "unsafe_set_contains", "value_library", "write_interventions"]
