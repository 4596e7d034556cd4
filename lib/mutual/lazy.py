"""A package's face that imports its heavier modules on first use (PEP 562's module ``__getattr__``).

A thrust lists in ``__all__`` what other thrusts, the command line and the notebooks' reports use. The
names whose modules load JAX, cvxpy or matplotlib, or that only a notebook's study needs, are given as
``{name: submodule}`` and imported when first read, so that ``import mutual.study`` (the statistics)
stays free of JAX and ``import mutual.constraints`` stays NumPy and SciPy alone.
"""

import importlib


def lazy_names(package, table):
    """The ``__getattr__`` of ``package`` that reads ``name`` from ``package.<table[name]>``, importing that
    module on first use. Nothing is copied into the package, so the face always hands out what the module
    holds now (a test that patches ``mutual.motion.spec.solve_legible`` patches ``mutual.motion``'s too)."""
    def __getattr__(name):
        if name not in table:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(f"{package}.{table[name]}"), name)
    return __getattr__
