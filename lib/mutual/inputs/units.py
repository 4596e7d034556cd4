"""Units users get wrong: angles in degrees where radians belong.

A periodic coordinate (a heading, a pendulum's angle) is read in radians. Degrees pass every check of a
number, and a fit on them comes out plausible but wrong, so a column of angles is looked at as a whole:

* values more than a full turn beyond their range (``[-pi, pi]`` for a heading, the box of a periodic
  state) -- radians that wind over several turns do that too, degrees nearly always;
* steps between consecutive samples of more than a quarter turn that are not a wrap-around -- a motion
  recorded in degrees moves 57 times too fast in radians.

:func:`angle_unit_warning` gives a warning that names the likely unit and what to do (or None), and
:func:`warn` issues it as an :class:`InputWarning` (the command line prints it as one line on stderr).
"""

import math
import warnings

import numpy as np

__all__ = ["InputWarning", "angle_unit_warning", "warn"]


class InputWarning(UserWarning):
    """An input that reads but is probably not what the user meant (a unit, a range); the result may be wrong."""


def warn(message):
    """Issue ``message`` as an :class:`InputWarning`."""
    warnings.warn(message, InputWarning, stacklevel=3)


def _steps(values, period):
    """Steps between consecutive samples that exceed a quarter turn and are not a wrap-around (a jump of about
    one period), and how many steps there are."""
    steps = np.abs(np.diff(values))
    wraps = np.abs(steps - period) < period / 4
    return int(np.sum((steps > period / 4) & ~wraps)), steps.size


def angle_unit_warning(values, where, low=-math.pi, high=math.pi, times=None):
    """A warning (text) when the angles ``values`` (radians, range ``[low, high]``, one period wide) look like
    degrees or another unit, or None. ``times``: a list of sample-time arrays, one per trajectory, when
    ``values`` is a list of trajectories (their steps are checked too); ``where``: what the message names."""
    tracks = [np.asarray(v, float) for v in values] if times is not None else [np.asarray(values, float)]
    flat = np.concatenate([t.ravel() for t in tracks]) if tracks else np.zeros(0)
    flat = flat[np.isfinite(flat)]
    if flat.size == 0:
        return None
    period = high - low
    top = float(np.max(np.abs(flat)))
    beyond = (flat < low - period) | (flat > high + period)
    jumps = [_steps(t, period) for t in tracks if t.size > 1] if times is not None else []
    fast, total = sum(j[0] for j in jumps), sum(j[1] for j in jumps)
    if not beyond.any() and not (total and fast > 0.05 * total):
        return None
    unit = "degrees (radians x 180/pi)" if top <= 360 * (1 + 1e-9) else "a unit other than radians"
    convert = "multiply by pi/180" if "degrees" in unit else "convert them to radians"
    seen = (f"{int(beyond.sum())} of {flat.size} values lie more than a full turn outside [{low:.4g}, {high:.4g}] "
            f"(up to {top:.4g})" if beyond.any() else
            f"{fast} of {total} steps between samples turn more than a quarter turn without wrapping around")
    return (f"{where}: the angles look like {unit}, not radians: {seen}; if so, {convert} "
            "(radians that wind over several turns are fine)")
