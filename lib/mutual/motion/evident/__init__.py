"""Chapter 7: evident safety, legible avoidance on nonlinear dynamics solved by iLQR.

Vehicle models (:mod:`.vehicles`: the Dubins car of eq. (7.5), the kinematic bicycle, the single
integrator); the feature-cost task, its hypotheses and the legible objective (:mod:`.safety`);
how evident a path's avoidance is (:mod:`.evidence`); legible model predictive control
(:mod:`.mpc`); the scans of what the thesis leaves open (:mod:`.scans`); Dragan and Srinivasa's legibility on
the Dubins car (:mod:`.dragan_car`); the observer's belief over time for a task (:mod:`.task_belief`); figures
(:mod:`.plots`) and the Explore view (:mod:`.explore`). The solver is :mod:`mutual.motion.trajopt`.
"""

from ...lazy import lazy_names
from .evidence import anticipates, close_but_clear, distance_table, distance_to_point, lead_time, obvious_avoidance
from .mpc import receding_horizon_ilqr, receding_horizon_ilqr_batch
from .safety import EvidentSafetyTask, figure_scenario, hypothesis_weights, solve_hypotheses
from .task_belief import belief_over_time
from .vehicles import bicycle_step, dubins_step

__all__ = ["EvidentSafetyTask", "anticipates", "belief_over_time", "bicycle_step", "close_but_clear",
           "distance_table", "distance_to_point", "dubins_step", "figure_61_scan", "figure_72_scan", "figure_scenario",
           "hazard_feature", "hypothesis_weights", "lead_time", "obvious_avoidance", "receding_horizon_ilqr",
           "receding_horizon_ilqr_batch", "solve_hypotheses", "time_both"]

# the scans of what the thesis leaves open and Dragan and Srinivasa on the car (notebook 06), on first use
__getattr__ = lazy_names(__name__, {"figure_61_scan": "scans", "figure_72_scan": "scans", "hazard_feature": "scans",
                                    "time_both": "dragan_car"})
