"""Constraints from continuous demonstrations (an extension: Section 3.4's next step).

The thesis's chapters 2-3 infer constraints on a gridworld; Section 3.4 names the next step,
handling the state as a continuous parameter by refining gridded state spaces (Stocking et al.
2021, the thesis's reference [67]). This subpackage builds it on chapters 2-3's MDP, soft backup,
chance thresholds and greedy inference:

* :mod:`.systems` -- continuous dynamics x' = f(x, u): named systems and your own ``module:function``;
* :mod:`.grid`, :mod:`.problem`, :mod:`.systemfile` -- the box and its cells, the controls, the
  task, the tabular MDP, and the system TOML file that describes them;
* :mod:`.discretization` -- S(x, a, x') by Monte Carlo within cells or by
  Kuhn-triangulation interpolation, in chunks that run in one process or on Dask;
* :mod:`.recordings`, :mod:`.mapping` -- recorded trajectories (CSV), aligned to the time step and
  mapped to cells and actions (controls inferred where they were not recorded);
* :mod:`.regions`, :mod:`.candidates`, :mod:`.thresholds` -- bounds, disks, boxes and cells as
  chance constraints with their maximum-likelihood thresholds (eq. 3.3, Lemma 3.2.1);
* :mod:`.pointwise`, :mod:`.occupancy`, :mod:`.evidence`, :mod:`.search`, :mod:`.inference` -- the default:
  the exact likelihood of continuous demonstrations of a deterministic system (Z on the grid, point by point),
  candidates as continuous parameters (the tightest consistent bound, the largest consistent obstacle),
  greedy inference with a stop rule on the exact gain and a likelihood interval per constraint;
* :mod:`.cells`, :mod:`.refine` -- chapters 2-3's greedy inference on the discretized MDP itself
  (``infer(..., model="cells")``), and refinement of its grid near an inferred boundary;
* :mod:`.demonstrators` -- demonstrators on the TRUE continuous system (fine-grid soft-optimal, MPPI);
* :mod:`.experiments`, :mod:`.soft_hjb`, :mod:`.plots` -- notebook 09's measurements and figures.
"""

from ...lazy import lazy_names
from .candidates import RegionCandidates, bound_regions, box_regions, disk_regions, region_candidates, threshold_table
from .demonstrators import mppi_rollouts, rollout, soft_demonstrator, starts_around
from .discretization import discretize
from .grid import Grid
from .cells import CellInference, infer_cells
from .inference import ContinuousInference, boundary_errors, infer
from .mapping import check_recording, to_demonstrations
from .pointwise import PointModel, file_weights, point_model
from .problem import Problem, QuadraticReward
from .recordings import Recording, read_recording, write_recording
from .regions import Bound, Box, Disk, boundary_distance, parse_region
from .systemfile import check_start, load_system, system_from_mapping
from .systems import SYSTEMS, System, integrate, named_system

__all__ = ["Bound", "Box", "CellInference", "ContinuousInference", "Disk", "Grid", "PointModel", "Problem",
           "QuadraticReward", "Recording", "RegionCandidates", "SYSTEMS", "System", "bound_regions",
           "boundary_distance", "boundary_errors", "box_regions", "check_recording", "check_start", "claim_verdict",
           "convergence", "demos_sweep", "discretize", "disk_regions", "file_weights", "infer", "infer_cells",
           "inference_figure", "integrate", "load_system", "mppi_rollouts", "named_system", "parse_region",
           "point_model", "read_recording", "refinement", "region_candidates", "resolution_sweep", "rollout",
           "soft_demonstrator", "starts_around", "summary", "system_from_mapping", "threshold_table",
           "timed_inference", "to_demonstrations", "with_cells", "write_recording"]

# notebook 09's measurements, the refinement, the soft HJB check and the figure, imported on first use
__getattr__ = lazy_names(__name__, {
    "with_cells": "experiments", "claim_verdict": "experiments", "summary": "experiments", "resolution_sweep": "experiments",
    "demos_sweep": "experiments", "timed_inference": "experiments", "refinement": "refine",
    "convergence": "soft_hjb", "inference_figure": "plots"})
