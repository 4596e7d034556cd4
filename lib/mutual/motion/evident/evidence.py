"""How evident a path's avoidance is (chapter 7): distances to a hazard, and how early a path
shows that it keeps away (the "anticipates safety well ahead of time" of section 7.3).

All measures take planar paths ``xs`` (N+1, n >= 2) sampled every ``dt`` seconds; only the
first two coordinates (the position ``P x``) are used.
"""

import numpy as np
import pandas as pd

from ...inputs import positive

# Fig. 7.2's "makes its avoidance obvious", fixed before any result: the integral distance at
# least 25% above both H0's and H1's, and the closest approach at least 1.5 times H1's
OBVIOUS_INTEGRAL_GAIN, OBVIOUS_MIN_RATIO = 0.25, 1.5
SEPARATION_MARGIN = 0.1  # a path has separated from H0 once it is this fraction of H0's closest approach farther


def _path(xs, name="xs"):
    xs = np.asarray(xs, float)
    if xs.ndim != 2 or xs.shape[1] < 2 or xs.shape[0] < 2:
        raise ValueError(f"{name} must have shape (N+1, n >= 2) with N >= 1, got {xs.shape}")
    if not np.all(np.isfinite(xs)):
        raise ValueError(f"{name} must be finite")
    return xs


def _point(point):
    p = np.asarray(point, float)
    if p.shape != (2,) or not np.all(np.isfinite(p)):
        raise ValueError(f"point must be a finite planar point of shape (2,), got {point!r}")
    return p


def distance_over_time(xs, point):
    """``|P x_k - h|`` for every knot of the path (N+1,)."""
    return np.linalg.norm(_path(xs)[:, :2] - _point(point), axis=1)


def distance_to_point(xs, point, dt):
    """Minimum and integral distance of the planar path ``P xs`` (N+1, n) to ``point``.

    The integral is ``int_0^T |P x(t) - h| dt`` by the trapezoid rule on the step grid.
    Returns ``{"min": ..., "integral": ...}``.
    """
    d = distance_over_time(xs, point)
    return {"min": float(d.min()), "integral": float(np.trapezoid(d, dx=positive("dt", dt)))}


def distance_table(results, point, dt):
    """Minimum and integral distance to ``point`` for each solved hypothesis, as a DataFrame."""
    rows = [{"hypothesis": name, **{f"{k} distance": v for k, v in distance_to_point(r.xs, point, dt).items()}}
            for name, r in results.items()]
    return pd.DataFrame(rows)


def obvious_avoidance(path, h0, h1, point, dt):
    """Fig. 7.2's rule for "makes its avoidance obvious": ``path``'s integral distance to ``point`` is
    at least ``OBVIOUS_INTEGRAL_GAIN`` above both H0's and H1's and its closest approach at least
    ``OBVIOUS_MIN_RATIO`` times H1's. Returns ``(holds, integral gain, min ratio)``."""
    d, d0, d1 = (distance_to_point(x, point, dt) for x in (path, h0, h1))
    gain = d["integral"] / max(d0["integral"], d1["integral"]) - 1
    ratio = d["min"] / d1["min"]
    return bool(gain >= OBVIOUS_INTEGRAL_GAIN and ratio >= OBVIOUS_MIN_RATIO), float(gain), float(ratio)


def lead_time(xs, reference, point, dt, margin=SEPARATION_MARGIN):
    """How long before the reference path (the ignorant H0) comes closest to ``point`` the path
    ``xs`` already keeps visibly farther from it (section 7.3's anticipation; defined before any
    result was seen).

    ``t_close``: the time of the reference's closest approach; ``t_separate``: the first time at
    which ``xs`` is farther from ``point`` than the reference by more than ``margin`` times the
    reference's closest approach (``inf`` if never); ``lead = t_close - t_separate`` (seconds,
    ``-inf`` if it never separates). Returns a dict of the three.
    """
    d, d_ref = distance_over_time(xs, point), distance_over_time(reference, point)
    if d.shape != d_ref.shape:
        raise ValueError(f"xs and reference must have the same number of knots, got {d.shape} and {d_ref.shape}")
    if not (np.isfinite(margin) and margin > 0):
        raise ValueError(f"margin must be a positive finite number, got {margin!r}")
    dt = positive("dt", dt)
    t_close = float(np.argmin(d_ref) * dt)
    apart = np.nonzero(d - d_ref > margin * d_ref.min())[0]
    t_sep = float(apart[0] * dt) if apart.size else np.inf
    return {"t_close": t_close, "t_separate": t_sep, "lead": t_close - t_sep}


def anticipates(xs, h0, h1, point, dt):
    """Section 7.3's "anticipates safety well ahead of time", as fixed before any result: ``xs``
    separates from the ignorant H0 path (:func:`lead_time`) no later than halfway to H0's closest
    approach, and before the avoidant H1 path does. Returns ``(holds, lead of xs, lead of H1)``
    with the leads as :func:`lead_time` dicts."""
    mine, theirs = lead_time(xs, h0, point, dt), lead_time(h1, h0, point, dt)
    holds = mine["t_separate"] <= 0.5 * mine["t_close"] and mine["t_separate"] < theirs["t_separate"]
    return bool(holds), mine, theirs


CLOSE_FACTOR = 2.0  # Fig. 6.1's "comes concerningly close": within twice the person's radius


def close_but_clear(min_distance, radius):
    """Fig. 6.1's H1 path: it avoids the person (closest approach beyond ``radius``) but comes
    concerningly close (within ``CLOSE_FACTOR`` radii)."""
    return bool(radius < min_distance < CLOSE_FACTOR * radius)
