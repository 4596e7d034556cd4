"""Continuous systems x' = f(x, u) (Section 3.4's continuous state): the named systems and the user's own.

A :class:`System` names its state coordinates and controls (with units), says which coordinates are
angles that wrap around, and holds the dynamics as a ``spec``: the name of a built-in system or
``"module:function"`` for your own. Every dynamics function is vectorized: ``f(x, u, **parameters)``
takes states ``x`` (N, n) and controls ``u`` (N, m) and returns dx/dt (N, n), with numpy.

Built-in systems (``SYSTEMS``; parameters and their defaults in each function's signature):

* ``pendulum`` -- a damped pendulum, theta = 0 hanging down, torque u:
  theta'' = (u - b theta' - m g l sin theta) / (m l^2);
* ``cartpole`` -- a cart (position x) with a pole (theta = 0 upright, half-length l), force u
  (Barto, Sutton and Anderson 1983, frictionless);
* ``unicycle`` -- chapter 4's Dubins car: x' = v cos h, y' = v sin h, h' = u (turn rate);
* ``double_integrator`` -- p' = v, v' = u (linear; the tests' independent truth).

:func:`integrate` advances states by a time step with classical Runge-Kutta (RK4) sub-steps, the
control held constant (zero-order hold), and refuses non-finite results with a message naming the
dynamics, the state and the control.
"""

import inspect
import math
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from ... import dubins
from ...inputs import UserFunction, call, load_function


def pendulum(x, u, mass=1.0, length=1.0, damping=0.1, gravity=9.81):
    """theta'' = (u - b theta' - m g l sin theta) / (m l^2); theta = 0 hanging down."""
    theta, omega = x[:, 0], x[:, 1]
    accel = (u[:, 0] - damping * omega - mass * gravity * length * np.sin(theta)) / (mass * length ** 2)
    return np.stack([omega, accel], axis=1)


def cartpole(x, u, cart_mass=1.0, pole_mass=0.1, pole_half_length=0.5, gravity=9.81):
    """The frictionless cart-pole of Barto, Sutton and Anderson (1983); theta = 0 upright."""
    v, theta, omega = x[:, 1], x[:, 2], x[:, 3]
    total = cart_mass + pole_mass
    sin, cos = np.sin(theta), np.cos(theta)
    temp = (u[:, 0] + pole_mass * pole_half_length * omega ** 2 * sin) / total
    alpha = (gravity * sin - cos * temp) / (pole_half_length * (4.0 / 3.0 - pole_mass * cos ** 2 / total))
    accel = temp - pole_mass * pole_half_length * alpha * cos / total
    return np.stack([v, accel, omega, alpha], axis=1)


def unicycle(x, u, speed=1.0):
    """Chapter 4's Dubins car at constant ``speed``: x' = v cos h, y' = v sin h, h' = u (:func:`mutual.dubins.derivative`)."""
    return dubins.derivative(x, u, speed)


def double_integrator(x, u):
    """p' = v, v' = u."""
    return np.stack([x[:, 1], u[:, 0]], axis=1)


#: name -> (dynamics, state names, state units, periodic coordinates, control names, control units)
SYSTEMS = {
    "pendulum": (pendulum, ("theta", "theta_dot"), ("rad", "rad/s"), ("theta",), ("torque",), ("N m",)),
    "cartpole": (cartpole, ("x", "x_dot", "theta", "theta_dot"), ("m", "m/s", "rad", "rad/s"), (),
                 ("force",), ("N",)),
    "unicycle": (unicycle, ("x", "y", "heading"), ("m", "m", "rad"), ("heading",), ("turn_rate",), ("rad/s",)),
    "double_integrator": (double_integrator, ("position", "velocity"), ("m", "m/s"), (), ("acceleration",),
                          ("m/s^2",)),
}


@lru_cache(maxsize=None)
def resolve_dynamics(spec, folder=None):
    """The dynamics named by ``spec``: a key of ``SYSTEMS`` or ``"module:function"``, as a
    :class:`mutual.inputs.UserFunction` (``module.py`` in ``folder`` -- the system file's folder -- first,
    then an installed module; :func:`mutual.inputs.load_function`). Importing the module runs its code."""
    if not isinstance(spec, str) or not spec:
        raise ValueError(f"system: must be a named system ({', '.join(SYSTEMS)}) or 'module:function', got {spec!r}")
    if spec in SYSTEMS:
        return UserFunction(SYSTEMS[spec][0], spec, None)
    if ":" not in spec:
        raise ValueError(f"system: {spec!r} is neither a named system ({', '.join(SYSTEMS)}) nor 'module:function'")
    return load_function(spec, folder, where="system")


@dataclass(frozen=True, eq=False)
class System:
    """A continuous system: ``spec`` (a named system or ``"module:function"``), its coordinate and
    control ``names`` and ``units``, the ``periodic`` coordinates (names) and keyword ``parameters``
    of the dynamics. ``folder``: where a user module is looked for first. Picklable (the function is
    looked up again from ``spec`` where it is used, e.g. on a Dask worker)."""

    spec: str
    state_names: tuple
    state_units: tuple
    control_names: tuple
    control_units: tuple
    periodic: tuple = ()
    parameters: dict = field(default_factory=dict)
    folder: str = None

    def __post_init__(self):
        for name in ("state_names", "state_units", "control_names", "control_units", "periodic"):
            object.__setattr__(self, name, tuple(str(v) for v in getattr(self, name)))
        if len(self.state_units) != len(self.state_names) or len(self.control_units) != len(self.control_names):
            raise ValueError("units: need one unit per state coordinate and per control")
        unknown = [p for p in self.periodic if p not in self.state_names]
        if unknown:
            raise ValueError(f"periodic: {unknown[0]!r} is not a state coordinate {list(self.state_names)}")
        function = resolve_dynamics(self.spec, self.folder).function
        _check_parameters(function, self.spec, dict(self.parameters))
        object.__setattr__(self, "parameters", dict(self.parameters))

    def __repr__(self):
        return f"System({self.spec!r}, x = ({', '.join(self.state_names)}), u = ({', '.join(self.control_names)}))"

    @property
    def n_states(self):
        return len(self.state_names)

    @property
    def n_controls(self):
        return len(self.control_names)

    @property
    def file(self):
        """The file of a user's dynamics (``"module:function"``): the code that runs; None for a named system."""
        return resolve_dynamics(self.spec, self.folder).file

    def f(self, x, u):
        """dx/dt (N, n) at states ``x`` (N, n) under controls ``u`` (N, m). An exception inside a user's
        function is a ValueError naming the function and its file."""
        out = call(resolve_dynamics(self.spec, self.folder), (x, u), self.parameters, f"system {self.spec!r}")
        try:
            out = np.asarray(out, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"system {self.spec!r}: the dynamics returned {type(out).__name__}, not an array of "
                             "numbers dx/dt") from None
        if out.shape != x.shape:
            raise ValueError(f"system {self.spec!r}: the dynamics returned shape {out.shape} for states of shape "
                             f"{x.shape}; it must return dx/dt with one row per state")
        return out


def named_system(name, parameters=None, **overrides):
    """A :class:`System` for a key of ``SYSTEMS`` with its default names and units."""
    if name not in SYSTEMS:
        raise ValueError(f"system: unknown named system {name!r}; known: {', '.join(SYSTEMS)}")
    _, states, units, periodic, controls, control_units = SYSTEMS[name]
    fields = dict(state_names=states, state_units=units, control_names=controls, control_units=control_units,
                  periodic=periodic, parameters=parameters or {})
    return System(name, **(fields | overrides))


def _check_parameters(function, spec, parameters):
    try:
        signature = inspect.signature(function)
    except (TypeError, ValueError):    # pragma: no cover - builtins
        return
    if any(p.kind == p.VAR_KEYWORD for p in signature.parameters.values()):
        return
    known = list(signature.parameters)[2:]
    for key, value in parameters.items():
        if key not in known:
            raise ValueError(f"parameters: {spec!r} takes no parameter {key!r} (it takes {', '.join(known) or 'none'})")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f"parameters: {key!r} must be a finite number, got {value!r}")


def integrate(system, x, u, dt, substeps=4):
    """States after ``dt`` seconds from ``x`` (N, n) under constant controls ``u`` (N, m) or (m,),
    by ``substeps`` RK4 steps. Periodic coordinates are not wrapped here (see ``Grid.wrap``)."""
    x = start = np.asarray(x, dtype=float)
    u = np.broadcast_to(np.asarray(u, dtype=float), (x.shape[0], system.n_controls))
    h = dt / substeps
    for _ in range(substeps):
        k1 = system.f(x, u)
        k2 = system.f(x + 0.5 * h * k1, u)
        k3 = system.f(x + 0.5 * h * k2, u)
        k4 = system.f(x + h * k3, u)
        x = x + (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)
    bad = ~np.isfinite(x).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"system {system.spec!r}: the dynamics gave a non-finite state after {dt:g} s from x = "
                         f"{_vector(start[i])} under u = {_vector(u[i])}; check the dynamics and its parameters")
    return x


def _vector(v):
    return "[" + ", ".join(f"{c:.4g}" for c in np.asarray(v)) + "]"


def folder_of(path):
    """The folder of a system file, as text (for :func:`resolve_dynamics`)."""
    return str(Path(path).resolve().parent)
