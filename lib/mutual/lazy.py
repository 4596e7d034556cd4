"""A package's face that imports its heavier modules on first use (PEP 562's module ``__getattr__``).

A thrust lists in ``__all__`` what other thrusts, the command line and the notebooks' reports use. The
names whose modules load JAX, cvxpy or matplotlib, or that only a notebook's study needs, are given as
``{name: submodule}`` and imported when first read, so that ``import mutual.study`` (the statistics)
stays free of JAX and ``import mutual.constraints`` stays NumPy and SciPy alone.
"""

import importlib
import sys


def lazy_names(package, table):
    """The ``__getattr__`` of ``package`` that reads ``name`` from ``package.<table[name]>`` on first use
    and keeps it in the package (later reads are plain attribute reads)."""
    def __getattr__(name):
        if name not in table:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{table[name]}"), name)
        setattr(sys.modules[package], name, value)
        return value
    return __getattr__
