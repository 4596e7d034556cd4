"""Thrust 1, chapter 4: learning a supervisor's safe set from their interventions.

HJI avoid sets of the Dubins car (:mod:`.dubins`, :mod:`.reachability`, eq. 4.3), the noisy
idealized supervisor (:mod:`.supervisor`, Sec. 4.3), the maximum-likelihood fit of their safe set
(:mod:`.fit`, eqs. 4.8-4.12) and control on a learned safe set (:mod:`.control`, Sec. 4.5).
"""

from .control import false_positive_rates, filter_control, safety_controller
from .fit import SupervisorFit, fit_supervisor
from .reachability import GridSpec, ValueFunction, ValueLibrary, avoid_value_function, value_library
from .supervisor import NoisySupervisor, read_interventions, write_interventions

__all__ = ["GridSpec", "NoisySupervisor", "SupervisorFit", "ValueFunction", "ValueLibrary", "avoid_value_function",
           "false_positive_rates", "filter_control", "fit_supervisor", "read_interventions", "safety_controller",
           "value_library", "write_interventions"]
