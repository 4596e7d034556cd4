"""Regenerate the SIMULATED example inputs of data/examples/ (documented in data/README.md).

    .venv/bin/python data/examples/regenerate.py [demonstrations|interventions|study|trajectories]

Fixed seeds: a second run writes the same files (up to the library's numerics). The examples are
simulated from the thesis's own generative models; they show the formats and let every command
run, and say nothing about people.
"""

import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent


def demonstrations():
    """100 demonstrations in the thesis's 9 x 9 world (world.toml) under the chapter 3 ground truth:
    chance constraints (psi = 0.25) on the bottom-middle cell and three upper cells, NW and SW forbidden."""
    from mutual.constraints import constraint_mask, sample_demonstrations, write_demonstrations
    from mutual.constraints.gridworld import GRID_ACTIONS
    from mutual.constraints.world import load_world
    grid = load_world(HERE / "world.toml")
    states = [grid.state(4, 0), grid.state(2, 6), grid.state(4, 7), grid.state(6, 6)]
    truth = constraint_mask(grid.mdp, states, 0.25, [GRID_ACTIONS.index("NW"), GRID_ACTIONS.index("SW")])
    write_demonstrations(HERE / "demonstrations.csv", sample_demonstrations(grid.mdp, 100, truth, rng=1))


def interventions():
    """Three simulated noisy idealized supervisors (Sec. 4.3), 30 interventions each, watching robots
    drive straight at a unit-radius obstacle from 7.5 away (the Phase II scenes of Sec. 5.2.1), on
    the full grid (the default of `mutual supervisor fit`)."""
    from mutual.supervision import NoisySupervisor, value_library, write_interventions
    from mutual.supervision import FULL_GRID
    from mutual.supervision.supervisor import approach_scenes
    supervisors = {"sim-01": (1.0, 0.3, 0.05), "sim-02": (0.75, 0.2, 0.05), "sim-03": (0.5, 0.5, 0.1)}
    library = value_library(0.25 * np.arange(1, 13), 1.0, FULL_GRID)
    rng = np.random.default_rng(2)
    rows = []
    for who, (w_max, mu, sigma) in supervisors.items():
        sup = NoisySupervisor(library[library.index_of(w_max)], mu, sigma)
        scenes = approach_scenes(60, rng, 1.0, 7.5)
        states, hit = sup.first_interventions(scenes, rng)
        states, hit = states[:30], hit[:30]
        time = np.linalg.norm(states[:, :2] - scenes[hit, 0, :2], axis=1) / 3.0   # straight at speed 3
        rows.append(pd.DataFrame({"participant": who, "trial": hit, "time": time, "x": states[:, 0],
                                  "y": states[:, 1], "theta": states[:, 2]}))
    write_interventions(pd.concat(rows, ignore_index=True), HERE / "interventions.csv")


def trajectories():
    """Continuous demonstrations (issue 21): 20 swing-ups of the pendulum of pendulum.toml by its
    [simulate] demonstrator under the hidden limit theta_dot <= 5 rad/s, with the torques recorded; and
    20 drives of the car of unicycle.toml past the hidden disk, without controls (inference infers them)."""
    from mutual.constraints.continuous import demonstrators as dm
    from mutual.constraints.continuous import load_system, write_recording
    for name, controls in (("pendulum", True), ("unicycle", False)):
        spec = load_system(HERE / f"{name}.toml")
        problem, sim = spec.problem, spec.simulate
        starts = dm.starts_around(sim["start"], sim["spread"], sim["n"], sim["seed"])
        demonstrator = dm.soft_demonstrator(problem, sim["hidden"], sim["fine_cells"], scheduler="inline")
        recording = dm.rollout(demonstrator, starts, sim["seed"] + 1)
        write_recording(HERE / f"{name}_trajectories.csv", recording, problem.system.state_names,
                        problem.system.control_names if controls else None)


def study():
    """The compendium's simulated Phase III table (data/ch5_simulated_phase3.csv), copied."""
    shutil.copyfile(HERE.parent / "ch5_simulated_phase3.csv", HERE / "study.csv")


if __name__ == "__main__":
    for name in sys.argv[1:] or ["demonstrations", "interventions", "study", "trajectories"]:
        {"demonstrations": demonstrations, "interventions": interventions, "study": study,
         "trajectories": trajectories}[name]()
