"""Random generators from the seeds a user gives (chapters 2-4 and wherever a seed is an input)."""

import numbers

import numpy as np

__all__ = ["generator"]


def generator(seed, name="seed"):
    """A ``numpy.random.Generator`` from ``seed``: a non-negative integer, None (fresh entropy) or a
    Generator (used as it is). Anything else (-1, NaN, 1.5, True, a string) is a ValueError naming
    ``name``, instead of numpy's message about SeedSequence."""
    if seed is None or isinstance(seed, np.random.Generator):
        return np.random.default_rng(seed)
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise ValueError(f"{name}: must be a non-negative integer (or a numpy Generator), got {seed!r}")
    return np.random.default_rng(int(seed))
