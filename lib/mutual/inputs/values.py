"""Checks of single values that users give (a function's argument, a key of a file, an option), with
one wording: ``NAME must be a number in [0, 1], got 1.5``.

* :func:`real`: a real number as a float (a 0-d array counts; a bool is not a number), else None;
* :func:`check_number`: a number within bounds, or a whole number / an integer, else a ValueError
  that names it, says what it must be and shows what it got with every digit it has
  (``-0.5000001`` is never rounded to the ``-0.5`` it violates);
* :func:`number_text`: the shortest text that reads back as the same number; :func:`shown`: a value
  for a message, cut when long.
"""

import math
import numbers

__all__ = ["check_number", "count", "describe", "exact_doubles", "finite", "number", "number_text", "positive", "probability", "real", "shown"]


def real(value):
    """``value`` as a float if it is a real number (a 0-d numpy array counts), else None; a bool is not a number,
    nor is an integer too large for a double."""
    if hasattr(value, "ndim") and getattr(value, "ndim") == 0 and hasattr(value, "item"):
        value = value.item()
    if isinstance(value, bool) or type(value).__name__ == "bool_" or not isinstance(value, numbers.Real):
        return None
    try:
        return float(value)
    except OverflowError:
        return None


def number_text(value):
    """The shortest text that reads back as the same number: ``repr`` of the double, a whole number without
    ``.0`` (an integer as written)."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return str(int(value))
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") and text != "-0.0" else text


def shown(value, limit=40):
    """``value`` for a message: numbers with every digit (:func:`number_text` for numpy's), else ``repr``, cut
    to about ``limit`` characters."""
    if hasattr(value, "item") and getattr(value, "ndim", None) == 0:
        value = value.item()
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit // 2]}...({len(text)} characters)"


def describe(low=None, high=None, low_open=False, high_open=False, whole=False, integer=False, finite=False):
    """What a value within these bounds is, in words: ``a number in [0, 1]``, ``an integer >= 1``, ...
    (``finite``: say "finite", for a value that is not)."""
    noun = "an integer" if integer or whole else "a finite number" if finite else "a number"
    if high is None and low == 0 and not (integer or whole):
        return "a positive finite number" if low_open else "a non-negative finite number"
    if low is not None and high is not None and not (math.isinf(low) or math.isinf(high)):
        if integer or whole:
            return f"{noun} in {number_text(low)}..{number_text(high)}"
        return (f"{noun} in {'(' if low_open else '['}{number_text(low)}, {number_text(high)}"
                f"{')' if high_open else ']'}")
    if low is not None:
        return f"{noun} {'>' if low_open else '>='} {number_text(low)}"
    if high is not None:
        return f"{noun} {'<' if high_open else '<='} {number_text(high)}"
    return noun if integer or whole else "a finite number"


def check_number(name, value, low=None, high=None, low_open=False, high_open=False, whole=False, integer=False,
                 what=None, sep=" "):
    """``value`` as a float (an int with ``whole`` or ``integer``) if it is a finite real number within the bounds,
    else a ValueError ``NAME must be <what>, got VALUE``.

    ``integer``: an int (numpy's too), never a float; ``whole``: any real number without a fraction
    (``40.0`` counts; both are "an integer" in the message); ``what``: the words after "must" (default: "be " + :func:`describe`); ``sep``: between the
    name and "must" (``": "`` for ``key 'x': must ...``).
    """
    x = real(value)
    ok = x is not None and math.isfinite(x)
    if ok and integer:
        ok = isinstance(value.item() if hasattr(value, "item") else value, numbers.Integral)
    if ok and whole:
        ok = x == int(x)
    if ok and low is not None:
        ok = x > low if low_open else x >= low
    if ok and high is not None:
        ok = x < high if high_open else x <= high
    if not ok:
        strictly = (low, high, low_open, high_open) == (0, 1, True, True) and not (integer or whole)
        said = what or "lie strictly between 0 and 1" if strictly else what or "be " + describe(low, high, low_open, high_open, whole, integer,
                                        finite=x is None or not math.isfinite(x))
        raise ValueError(f"{name}{sep}must {said}, got {shown(value)}")
    if integer or whole:
        return int(value.item() if hasattr(value, "item") else value) if integer else int(x)
    return x


def positive(name, value):
    """``value`` as a float if it is a finite number > 0, else a ValueError naming ``name``."""
    return check_number(name, value, low=0, low_open=True)


def finite(name, value):
    """``value`` as a float if it is a finite number, else a ValueError naming ``name``."""
    return check_number(name, value)


def count(name, value, low=1):
    """``value`` as an int if it is a whole number >= ``low`` (``40.0`` counts), else a ValueError naming ``name``."""
    return check_number(name, value, low=low, whole=True)


def number(name, value):
    """``value`` as a float if it is a real number (infinities and NaN included: the caller says what it allows),
    else a ValueError naming ``name``."""
    x = real(value)
    if x is None:
        raise ValueError(f"{name} must be a number, got {shown(value)}")
    return x


def probability(name, value):
    """``value`` as a float strictly between 0 and 1 (a level, a power, a confidence), else a ValueError."""
    return check_number(name, value, 0, 1, low_open=True, high_open=True)


def exact_doubles(name, values):
    """``values`` (numbers; integers of any size, numpy's or Python's) as float64, refusing two that differ but read
    as the same double -- integers beyond 2^53, say -- with a ValueError naming ``name``: a statistic of them would
    see no difference where the data have one."""
    import numpy as np
    raw = np.asarray(values)
    floats = raw.astype(float)
    if raw.dtype.kind in "iuO" and raw.size:
        exact = {}
        for v, f in zip(raw.tolist(), floats.tolist()):
            first = exact.setdefault(f, v)
            if first != v:
                raise ValueError(f"{name}: {first} and {v} differ only beyond the 15-17 significant digits of a double "
                                 f"(both read as {number_text(f)}), so no statistic can tell them apart; subtract a "
                                 "common offset (or change the unit) and run again")
    return floats
