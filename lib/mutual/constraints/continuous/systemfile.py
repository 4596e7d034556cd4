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
raises a ValueError naming the file and the key (``table.key``).
"""

import math
from dataclasses import dataclass, field

from ...tomlfile import read_toml
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


class _Reader:
    def __init__(self, mapping, source):
        self.m, self.source = mapping, source

    def fail(self, key, reason):
        raise ValueError(f"{self.source}: key {key!r}: {reason}")

    def table(self, name):
        value = self.m.get(name, {})
        if not isinstance(value, dict):
            self.fail(name, "must be a table [" + name + "]")
        known = _TABLES[name]
        for key in value:
            if known is not None and key not in known:
                self.fail(f"{name}.{key}", f"unknown key (known: {', '.join(known)})")
        for key in _REQUIRED.get(name, ()):
            if key not in value:
                self.fail(f"{name}.{key}", "missing (required)")
        return value

    def number(self, table, name, key, low=-math.inf, integer=False, default=None, strict_low=False):
        value = table.get(key, default)
        ok = not isinstance(value, bool) and isinstance(value, (int,) if integer else (int, float))
        if not ok or not math.isfinite(value) or value < low or (strict_low and value == low):
            kind = "an integer" if integer else "a number"
            self.fail(f"{name}.{key}", f"must be {kind} {'>' if strict_low else '>='} {low:g}, got {value!r}"
                      if math.isfinite(low) else f"must be {kind}, got {value!r}")
        return value

    def numbers(self, table, name, key, n=None, default=None, low=-math.inf, integer=False):
        value = table.get(key, default)
        if (not isinstance(value, list) or (n is not None and len(value) != n) or not value
                or any(isinstance(v, bool) or not isinstance(v, (int,) if integer else (int, float))
                       or not math.isfinite(v) or v < low for v in value)):
            what = f"{n} " if n is not None else ""
            self.fail(f"{name}.{key}", f"must be a list of {what}{'integers' if integer else 'numbers'}"
                                       f"{f' >= {low:g}' if math.isfinite(low) else ''}, got {value!r}")
        return [float(v) if not integer else int(v) for v in value]

    def texts(self, table, name, key, n=None, default=None):
        value = table.get(key, default)
        if not isinstance(value, list) or (n is not None and len(value) != n) or not all(isinstance(v, str) for v in value):
            self.fail(f"{name}.{key}", f"must be a list of {'' if n is None else f'{n} '}names (text), got {value!r}")
        return list(value)


def _system(r, spec, path):
    if not isinstance(spec, str):
        r.fail("system", f"must be a named system ({', '.join(SYSTEMS)}) or 'module:function', got {spec!r}")
    state, control, params = r.table("state"), r.table("control"), r.table("parameters")
    named = SYSTEMS.get(spec)
    if named is None and ":" not in spec:
        r.fail("system", f"{spec!r} is neither a named system ({', '.join(SYSTEMS)}) nor 'module:function'")
    n = len(r.numbers(state, "state", "low"))
    if named and n != len(named[1]):
        r.fail("state.low", f"system {spec!r} has {len(named[1])} coordinates ({', '.join(named[1])}), got {n}")
    defaults = named[1:] if named else (None, None, (), None, None)
    names = r.texts(state, "state", "names", n, list(defaults[0]) if named else None)
    units = r.texts(state, "state", "units", n, list(defaults[1]) if named else [""] * n)
    periodic = r.texts(state, "state", "periodic", None, list(defaults[2]))
    control_names = r.texts(control, "control", "names", None, list(defaults[3]) if named else None)
    control_units = r.texts(control, "control", "units", len(control_names),
                            list(defaults[4]) if named else [""] * len(control_names))
    try:
        return System(spec, names, units, control_names, control_units, periodic, params,
                      None if named else folder_of(path))
    except ValueError as err:
        r.fail("system" if "system" in str(err) else "parameters", str(err))


def _problem(r, system):
    state, control, time, disc, reward = (r.table(t) for t in ("state", "control", "time", "discretization", "reward"))
    n, m = system.n_states, system.n_controls
    low, high = r.numbers(state, "state", "low", n), r.numbers(state, "state", "high", n)
    if any(h <= lo for lo, h in zip(low, high)):
        r.fail("state.high", "every high must exceed its low")
    cells = r.numbers(state, "state", "cells", n, low=2, integer=True)
    grid = Grid.uniform(low, high, cells, [name in system.periodic for name in system.state_names],
                        system.state_names, system.state_units)
    values = control.get("values")
    flat = isinstance(values, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
    if m == 1 and flat:
        controls = [[v] for v in r.numbers(control, "control", "values")]
    else:
        if not isinstance(values, list) or not values or not all(isinstance(v, list) and len(v) == m for v in values):
            r.fail("control.values", f"must be a list of controls, each a list of {m} numbers, got {values!r}")
        controls = [r.numbers({"v": v}, "control", "values", m) for v in values]
    rw = QuadraticReward(r.numbers(reward, "reward", "goal", n),
                         r.numbers(reward, "reward", "state_weights", n, [1.0] * n, low=0),
                         r.numbers(reward, "reward", "control_weights", m, [0.0] * m, low=0),
                         r.numbers(reward, "reward", "terminal_weights", n, [0.0] * n, low=0),
                         r.number(reward, "reward", "temperature", 0, default=1.0, strict_low=True))
    scheme = disc.get("scheme", "sample")
    if scheme not in SCHEMES:
        r.fail("discretization.scheme", f"must be one of {list(SCHEMES)}, got {scheme!r}")
    try:
        return Problem(system, grid, controls, r.number(time, "time", "dt", 0, strict_low=True),
                       r.number(time, "time", "horizon", 1, integer=True), rw, scheme,
                       r.number(disc, "discretization", "samples", 1, integer=True, default=16),
                       r.number(time, "time", "substeps", 1, integer=True, default=4),
                       r.number(disc, "discretization", "seed", 0, integer=True, default=0))
    except ValueError as err:
        r.fail("control.values" if "controls" in str(err) else "state", str(err))


def _plane(r, table, name, system):
    plane = r.texts(table, name, "plane", 2, list(system.state_names[:2]))
    unknown = [p for p in plane if p not in system.state_names]
    if unknown:
        r.fail(f"{name}.plane", f"{unknown[0]!r} is not a state coordinate {list(system.state_names)}")
    return tuple(system.state_names.index(p) for p in plane)


def _candidates(r, system):
    c = r.table("candidates")
    out = {"families": r.texts(c, "candidates", "families", None, ["bound"]), "plane": _plane(r, c, "candidates", system),
           "every": r.number(c, "candidates", "every", 1, integer=True, default=2)}
    for key in ("radii", "half_widths"):
        out[key] = r.numbers(c, "candidates", key, None, low=0) if key in c else None
    from .candidates import FAMILIES
    bad = [f for f in out["families"] if f not in FAMILIES]
    if bad:
        r.fail("candidates.families", f"unknown family {bad[0]!r}; choose from {list(FAMILIES)}")
    return out


def _simulate(r, problem, plane):
    s, n = r.table("simulate"), problem.grid.ndim
    hidden = r.texts(s, "simulate", "hidden", None, [])
    try:
        regions = [parse_region(text, problem.grid.names, plane) for text in hidden]
    except ValueError as err:
        r.fail("simulate.hidden", str(err))
    demonstrator = s.get("demonstrator", "soft")
    if demonstrator not in ("soft", "mppi"):
        r.fail("simulate.demonstrator", f"must be 'soft' or 'mppi', got {demonstrator!r}")
    return {"hidden": regions, "hidden_text": hidden, "demonstrator": demonstrator,
            "start": r.numbers(s, "simulate", "start", n, list(0.5 * (problem.grid.low + problem.grid.high))),
            "spread": r.numbers(s, "simulate", "spread", n, [0.0] * n, low=0),
            "n": r.number(s, "simulate", "n", 1, integer=True, default=20),
            "seed": r.number(s, "simulate", "seed", 0, integer=True, default=0),
            "fine_cells": r.numbers(s, "simulate", "fine_cells", n, [3 * c for c in problem.grid.shape], low=2,
                                    integer=True),
            "temperature": r.number(s, "simulate", "temperature", 0, default=problem.reward.temperature,
                                    strict_low=True),
            "noise": r.number(s, "simulate", "noise", 0, default=0.0),
            "record_every": r.number(s, "simulate", "record_every", 1, integer=True, default=1),
            "samples": r.number(s, "simulate", "samples", 2, integer=True, default=256),
            "plan_steps": r.number(s, "simulate", "plan_steps", 1, integer=True, default=20),
            "sigma": r.number(s, "simulate", "sigma", 0, default=0.5, strict_low=True),
            "margin": r.number(s, "simulate", "margin", 0, default=0.0)}


def system_from_mapping(mapping, source="system", path=None):
    """Check a system file's mapping (as TOML reads it) and build its :class:`SystemFile`."""
    if not isinstance(mapping, dict):
        raise ValueError(f"{source}: must be a table of keys")
    r = _Reader(mapping, source)
    unknown = [k for k in mapping if k != "system" and k not in _TABLES]
    if unknown:
        r.fail(unknown[0], f"unknown key or table (known: system, {', '.join(_TABLES)})")
    if "system" not in mapping:
        r.fail("system", "missing (required): a named system or 'module:function'")
    system = _system(r, mapping["system"], path or source)
    problem = _problem(r, system)
    candidates = _candidates(r, system)
    return SystemFile(problem, candidates, _simulate(r, problem, candidates["plane"]), source)


def load_system(path):
    """Read a system TOML file (module docstring); errors name the file and the key."""
    return system_from_mapping(read_toml(path), str(path), path)
