"""The system TOML file of ``mutual constraints infer-continuous`` and ``simulate`` (data/README.md).

Tables and keys (``[candidates]`` and ``[simulate]`` are optional)::

    system = "pendulum"         # a named system (mutual.constraints.continuous.systems.SYSTEMS) or "module:function"
    [parameters]                # keyword arguments of the dynamics (default: the function's own)
    [state]    names, units, low, high, cells, periodic   # names/units default to a named system's
    [control]  names, units, values                       # values: the control set (numbers, or lists)
    [time]     dt, horizon, substeps
    [discretization]  scheme ("sample" or "barycentric"), samples, seed
    [reward]   goal, state_weights, control_weights, terminal_weights, temperature
    [candidates]  families, plane, every, radii, half_widths
    [simulate]    hidden, start, spread, n, seed, demonstrator ("soft" or "mppi"), fine_cells,
                  temperature, noise, record_every, samples, plan_steps, sigma, margin

Every mistake -- an unknown table or key, a missing one, a value of the wrong kind or length --
raises a ValueError naming the file and the key (``table.key``; :class:`mutual.inputs.Keys`). So do
dynamics written for one state at a time (they are called once on a small batch of states from the
box, :func:`check_vectorized`) and a ``[simulate] start`` inside a hidden region (:func:`check_start`).
``system = "module:function"`` runs that module's code (:mod:`mutual.inputs.usercode`).
"""

from dataclasses import dataclass, field

import numpy as np

from ...inputs import Keys, read_toml
from .grid import Grid
from .problem import SCHEMES, Problem, QuadraticReward
from .regions import parse_region
from .systems import SYSTEMS, System, folder_of

_TABLES = {"parameters": None,
           "state": ("names", "units", "low", "high", "cells", "periodic"),
           "control": ("names", "units", "values"),
           "time": ("dt", "horizon", "substeps"),
           "discretization": ("scheme", "samples", "seed"),
           "reward": ("goal", "state_weights", "control_weights", "terminal_weights", "temperature"),
           "candidates": ("families", "plane", "every", "radii", "half_widths"),
           "simulate": ("hidden", "start", "spread", "n", "seed", "demonstrator", "fine_cells", "temperature",
                        "noise", "record_every", "samples", "plan_steps", "sigma", "margin")}
_REQUIRED = {"state": ("low", "high", "cells"), "control": ("values",), "time": ("dt", "horizon"),
             "reward": ("goal",)}


@dataclass(frozen=True, eq=False)
class SystemFile:
    """A read system file: the ``problem``, the ``candidates`` settings and the ``simulate`` settings."""
    problem: Problem
    candidates: dict = field(default_factory=dict)
    simulate: dict = field(default_factory=dict)
    source: str = "system"


def _system(keys, spec, path):
    if not isinstance(spec, str):
        keys.fail("system", f"must be a named system ({', '.join(SYSTEMS)}) or 'module:function', got {spec!r}")
    state, control = keys.table("state", _TABLES["state"]), keys.table("control", _TABLES["control"])
    params = keys.table("parameters").mapping
    named = SYSTEMS.get(spec)
    if named is None and ":" not in spec:
        keys.fail("system", f"{spec!r} is neither a named system ({', '.join(SYSTEMS)}) nor 'module:function'")
    n = len(state.numbers("low"))
    if named and n != len(named[1]):
        state.fail("low", f"system {spec!r} has {len(named[1])} coordinates ({', '.join(named[1])}), got {n}")
    defaults = named[1:] if named else (None, None, (), None, None)
    for table, what in ((state, f"its {n} state coordinates"), (control, "its controls")):
        if not named and "names" not in table.mapping:
            table.fail("names", f"missing: a system given as 'module:function' names {what} (a list of names)")
    names = state.texts("names", n, list(defaults[0]) if named else None)
    units = state.texts("units", n, list(defaults[1]) if named else [""] * n)
    periodic = state.texts("periodic", None, list(defaults[2]))
    control_names = control.texts("names", None, list(defaults[3]) if named else None)
    control_units = control.texts("units", len(control_names), list(defaults[4]) if named else [""] * len(control_names))
    try:
        return System(spec, names, units, control_names, control_units, periodic, params,
                      None if named else folder_of(path))
    except ValueError as err:
        text = str(err).removeprefix("system: ")
        keys.fail("system" if "system" in str(err) else "parameters", text)


def _controls(control, m):
    """The control set: a list of numbers (one control), or a list of lists of ``m`` numbers."""
    values = control.get("values")
    flat = isinstance(values, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
    if m == 1 and flat:
        return [[v] for v in control.numbers("values")]
    if not isinstance(values, list) or not values or not all(isinstance(v, list) and len(v) == m for v in values):
        control.fail("values", f"must be a list of controls, each a list of {m} numbers, got {values!r}")
    return [control.numbers(f"values[{i}]", m, value=v) for i, v in enumerate(values)]


def _problem(keys, system):
    state, control, time, disc, reward = (keys.table(t, _TABLES[t], _REQUIRED.get(t, ()))
                                          for t in ("state", "control", "time", "discretization", "reward"))
    n, m = system.n_states, system.n_controls
    low, high = state.numbers("low", n), state.numbers("high", n)
    if any(h <= lo for lo, h in zip(low, high)):
        state.fail("high", "every high must exceed its low")
    cells = state.numbers("cells", n, low=2, integer=True)
    for name, unit, lo, hi in zip(system.state_names, system.state_units, low, high):
        if name in system.periodic and unit == "rad" and abs(hi - lo - 2 * np.pi) > 1e-3 * 2 * np.pi:
            state.fail("high", f"the periodic coordinate {name!r} (rad) wraps with period high - low = {hi - lo:.6g}, "
                               f"not 2 pi = {2 * np.pi:.6g}{' (degrees?)' if abs(hi - lo - 360) < 1e-6 else ''}: give "
                               "its box in radians, one turn wide (e.g. [-3.141592653589793, 3.141592653589793])")
    grid = Grid.uniform(low, high, cells, [name in system.periodic for name in system.state_names],
                        system.state_names, system.state_units)
    rw = QuadraticReward(reward.numbers("goal", n), reward.numbers("state_weights", n, 0, [1.0] * n),
                         reward.numbers("control_weights", m, 0, [0.0] * m),
                         reward.numbers("terminal_weights", n, 0, [0.0] * n),
                         reward.number("temperature", 0, low_open=True, default=1.0))
    scheme, controls = disc.choice("scheme", SCHEMES, default="sample"), _controls(control, m)
    try:
        problem = Problem(system, grid, controls, time.number("dt", 0, low_open=True),
                          time.number("horizon", 1, integer=True), rw, scheme,
                          disc.number("samples", 1, integer=True, default=16),
                          time.number("substeps", 1, integer=True, default=4),
                          disc.number("seed", 0, integer=True, default=0))
    except ValueError as err:
        keys.fail("control.values" if "controls" in str(err) else "state", str(err))
    check_vectorized(keys, problem)
    return problem


def check_vectorized(keys, problem):
    """Call the dynamics once on a small batch of states spread over the box (never as many states as
    coordinates or controls, so that a function written for one state cannot pass by accident): a failure,
    or a result that is not one row dx/dt per state, is refused naming the key ``system`` and the shapes."""
    grid, system = problem.grid, problem.system
    N = max(grid.ndim, problem.controls.shape[1]) + 2
    x = grid.low + (grid.high - grid.low) * ((np.arange(N)[:, None] + 0.5) / N + 0.37 * np.arange(grid.ndim)) % 1
    u = problem.controls[np.arange(N) % len(problem.controls)]
    shape = f"states x of shape {x.shape} and controls u of shape {u.shape}"
    vectorized = (f"the dynamics must take a batch of states x (N, {grid.ndim}) and controls u (N, {u.shape[1]}) and "
                  f"return dx/dt (N, {grid.ndim}); a function written for one state at a time fails so: write "
                  "x[:, 0] for the first coordinate of every state, np.stack([...], axis=1) for the result")
    try:
        system.f(x, u)
    except ValueError as err:
        keys.fail("system", f"called with {shape}: {str(err).removeprefix(f'system {system.spec!r}: ')}; {vectorized}")


def _plane(keys, table, system):
    plane = table.texts("plane", 2, list(system.state_names[:2]))
    unknown = [p for p in plane if p not in system.state_names]
    if unknown:
        table.fail("plane", f"{unknown[0]!r} is not a state coordinate {list(system.state_names)}")
    return tuple(system.state_names.index(p) for p in plane)


def _candidates(keys, system):
    from .candidates import FAMILIES
    c = keys.table("candidates", _TABLES["candidates"])
    out = {"families": c.texts("families", None, ["bound"]), "plane": _plane(keys, c, system),
           "every": c.number("every", 1, integer=True, default=2)}
    for key in ("radii", "half_widths"):
        out[key] = c.numbers(key, None, low=0) if key in c else None
    bad = [f for f in out["families"] if f not in FAMILIES]
    if bad:
        c.fail("families", f"unknown family {bad[0]!r}; choose from {list(FAMILIES)}")
    return out


def check_start(regions, texts, start, spread, where):
    """Refuse a start box ``start +- spread`` whose centre, or every point, lies in a hidden region: the
    demonstrator never enters one, so it cannot start there (``where`` names the input in the error)."""
    start, spread = np.asarray(start, float), np.asarray(spread, float)
    corners = start + spread * np.array(np.meshgrid(*[[-1.0, 1.0]] * start.size)).reshape(start.size, -1).T
    for region, text in zip(regions, texts):
        if region.inside(start[None])[0] or region.inside(corners).all():
            at = "the start" if not spread.any() else "the start (and every corner of start +- spread)"
            raise ValueError(f"{where}: {at} {list(map(float, start))} lies inside the hidden region {text!r}, which "
                             "the demonstrator never enters; move the start out of it or change the constraint")


def _simulate(keys, problem, plane):
    s, n = keys.table("simulate", _TABLES["simulate"]), problem.grid.ndim
    hidden = s.texts("hidden", None, [])
    try:
        regions = [parse_region(text, problem.grid.names, plane) for text in hidden]
    except ValueError as err:
        s.fail("hidden", str(err))
    out = {"hidden": regions, "hidden_text": hidden, "demonstrator": s.choice("demonstrator", ("soft", "mppi"),
                                                                               default="soft"),
           "start": s.numbers("start", n, default=list(0.5 * (problem.grid.low + problem.grid.high))),
           "spread": s.numbers("spread", n, 0, [0.0] * n),
           "n": s.number("n", 1, integer=True, default=20), "seed": s.number("seed", 0, integer=True, default=0),
           "fine_cells": s.numbers("fine_cells", n, 2, [3 * c for c in problem.grid.shape], integer=True),
           "temperature": s.number("temperature", 0, low_open=True, default=problem.reward.temperature),
           "noise": s.number("noise", 0, default=0.0),
           "record_every": s.number("record_every", 1, integer=True, default=1),
           "samples": s.number("samples", 2, integer=True, default=256),
           "plan_steps": s.number("plan_steps", 1, integer=True, default=20),
           "sigma": s.number("sigma", 0, low_open=True, default=0.5), "margin": s.number("margin", 0, default=0.0)}
    check_start(regions, hidden, out["start"], out["spread"], f"{keys.source}: key 'simulate.start'")
    return out


def system_from_mapping(mapping, source="system", path=None):
    """Check a system file's mapping (as TOML reads it) and build its :class:`SystemFile`."""
    keys = Keys(mapping, source)
    keys.known(("system",) + tuple(_TABLES), what="key or table")
    if "system" not in mapping:
        keys.fail("system", "missing (required): a named system or 'module:function'")
    system = _system(keys, mapping["system"], path or source)
    problem = _problem(keys, system)
    candidates = _candidates(keys, system)
    return SystemFile(problem, candidates, _simulate(keys, problem, candidates["plane"]), source)


def load_system(path):
    """Read a system TOML file (module docstring); errors name the file and the key."""
    return system_from_mapping(read_toml(path), str(path), path)
