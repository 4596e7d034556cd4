"""The benchmark's four systems as a user would describe them: system files and hidden truths.

Each system is the system TOML file a new user would write for ``mutual constraints infer-continuous``
(``systems/<name>.toml`` beside this module; data/README.md: the box, its cells, the control set, the
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
from pathlib import Path

from ..regions import parse_region
from ..systemfile import load_system

SYSTEMS = Path(__file__).with_name("systems")  # the four system files: pendulum.toml, double_integrator.toml, ...


@dataclass(frozen=True)
class Setup:
    """A benchmark system: its ``name`` (its file is ``systems/<name>.toml``), the demonstrators' own time
    step ``demo_dt`` (seconds; recordings are sampled at it), and its ``truths`` by key (text)."""

    name: str
    demo_dt: float
    truths: dict

    @property
    def path(self):
        return SYSTEMS / f"{self.name}.toml"

    @property
    def text(self):
        """The system file's text, as a user would hand it to the command line."""
        return self.path.read_text()

    def system_file(self):
        """The :class:`~mutual.constraints.continuous.systemfile.SystemFile` the file describes."""
        return load_system(self.path)

    def truth(self, key):
        """The hidden regions of truth ``key`` (an empty list for "U")."""
        spec = self.system_file()
        texts = self.truths[key]
        return [parse_region(t, spec.problem.grid.names, spec.candidates["plane"]) for t in texts]


SETUPS = {
    "pendulum": Setup("pendulum", 0.05, {
        "A": ["theta_dot <= 5.0"], "B": ["theta_dot >= -4.5"], "F": ["theta_dot <= 7.5"], "U": []}),
    "double_integrator": Setup("double_integrator", 0.05, {
        "A": ["position <= 2.3"], "B": ["velocity <= 0.8"], "F": ["velocity >= -1.5"], "U": []}),
    "cartpole": Setup("cartpole", 0.05, {
        "A": ["x_dot <= 0.5"], "B": ["theta <= 0.08"], "F": ["x >= -1.5"], "U": []}),
    "car": Setup("car", 0.05, {
        "A": ["disk 0 0 0.8"], "B": ["box -0.4 0.6 -1.2 0.4"], "F": ["disk 1.0 2.2 0.5"], "U": []}),
}
