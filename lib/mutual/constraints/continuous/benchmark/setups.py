"""The benchmark's four systems as a user would describe them: system files and hidden truths.

Each system is given as the text of the system TOML file a new user would write for
``mutual constraints infer-continuous`` (data/README.md: the box, its cells, the control set, the
time step, the horizon and the task), with the method's defaults everywhere else (temperature,
discretization, candidate radii). The dynamics are the library's named systems; everything the
benchmark's demonstrators do is their own (:mod:`.demonstrators`).

Truths per system (the text form of :func:`mutual.constraints.continuous.parse_region`):

* ``"A"`` and ``"B"`` -- constraints whose limit the demonstrators approach (a safety filter makes
  them ride it): a speed and an angle limit of the pendulum, a wall and a speed limit of the double
  integrator, a speed limit and a track end of the cart-pole, a disk and a box before the car;
* ``"F"`` -- a constraint they stay well away from (nothing in the data shows it);
* ``"U"`` -- none: unconstrained recordings, on which every accepted constraint is a false positive.
"""

from dataclasses import dataclass

from ....inputs import parse_toml
from ..regions import parse_region
from ..systemfile import system_from_mapping

PENDULUM = """\
# A torque-limited pendulum swinging up from hanging (theta = 0) to upright (theta = pi).
system = "pendulum"
[state]
low = [-3.141592653589793, -8.0]
high = [3.141592653589793, 8.0]
cells = [41, 41]
periodic = ["theta"]
[control]
values = [-3.0, -1.5, 0.0, 1.5, 3.0]
[time]
dt = 0.1
horizon = 60
[reward]
goal = [3.141592653589793, 0.0]
state_weights = [1.0, 0.05]
control_weights = [0.02]
terminal_weights = [10.0, 1.0]
[candidates]
families = ["bound"]
"""

DOUBLE_INTEGRATOR = """\
# A cart on a rail (position, velocity; acceleration) driving from 0 to 3 m.
system = "double_integrator"
[state]
low = [-1.0, -2.0]
high = [4.0, 2.0]
cells = [41, 41]
[control]
values = [-1.0, -0.5, 0.0, 0.5, 1.0]
[time]
dt = 0.1
horizon = 60
[reward]
goal = [3.0, 0.0]
state_weights = [1.0, 0.1]
control_weights = [0.1]
terminal_weights = [5.0, 1.0]
[candidates]
families = ["bound"]
"""

CARTPOLE = """\
# A cart-pole moving its cart from x = -1 to x = +1 m with the pole upright (theta = 0).
system = "cartpole"
[state]
low = [-1.6, -1.6, -0.6, -2.5]
high = [1.6, 1.6, 0.6, 2.5]
cells = [12, 12, 12, 12]
[control]
values = [-6.0, -3.0, 0.0, 3.0, 6.0]
[time]
dt = 0.1
horizon = 50
[discretization]
scheme = "barycentric"
[reward]
goal = [1.0, 0.0, 0.0, 0.0]
state_weights = [1.0, 0.1, 30.0, 0.5]
control_weights = [0.005]
terminal_weights = [10.0, 1.0, 30.0, 1.0]
[candidates]
families = ["bound"]
"""

CAR = """\
# A car at 1 m/s (chapter 4's Dubins car) driving from x = -2.5 to a goal at (2.5, 0) m.
system = "unicycle"
[state]
low = [-3.5, -3.0, -3.141592653589793]
high = [5.0, 3.0, 3.141592653589793]
cells = [27, 20, 12]
periodic = ["heading"]
[control]
values = [-1.0, -0.5, 0.0, 0.5, 1.0]
[time]
dt = 0.25
horizon = 24
[reward]
goal = [2.5, 0.0, 0.0]
state_weights = [0.5, 0.5, 0.0]
control_weights = [0.05]
terminal_weights = [3.0, 3.0, 0.0]
[candidates]
families = ["bound", "disk", "box"]
plane = ["x", "y"]
"""


@dataclass(frozen=True)
class Setup:
    """A benchmark system: its ``name``, the user's system-file ``text``, the demonstrators' own time
    step ``demo_dt`` (seconds; recordings are sampled at it), and its ``truths`` by key (text)."""

    name: str
    text: str
    demo_dt: float
    truths: dict

    def system_file(self):
        """The :class:`~mutual.constraints.continuous.systemfile.SystemFile` the text describes."""
        source = f"<benchmark {self.name}.toml>"
        return system_from_mapping(parse_toml(self.text, source), source)

    def truth(self, key):
        """The hidden regions of truth ``key`` (an empty list for "U")."""
        spec = self.system_file()
        texts = self.truths[key]
        return [parse_region(t, spec.problem.grid.names, spec.candidates["plane"]) for t in texts]


SETUPS = {
    "pendulum": Setup("pendulum", PENDULUM, 0.05, {
        "A": ["theta_dot <= 5.0"], "B": ["theta_dot >= -4.5"], "F": ["theta_dot <= 7.5"], "U": []}),
    "double_integrator": Setup("double_integrator", DOUBLE_INTEGRATOR, 0.05, {
        "A": ["position <= 2.3"], "B": ["velocity <= 0.8"], "F": ["velocity >= -1.5"], "U": []}),
    "cartpole": Setup("cartpole", CARTPOLE, 0.05, {
        "A": ["x_dot <= 0.5"], "B": ["theta <= 0.08"], "F": ["x >= -1.5"], "U": []}),
    "car": Setup("car", CAR, 0.05, {
        "A": ["disk 0 0 0.8"], "B": ["box -0.4 0.6 -1.2 0.4"], "F": ["disk 1.0 2.2 0.5"], "U": []}),
}
