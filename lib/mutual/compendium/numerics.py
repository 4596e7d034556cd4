"""The same bits on every x86-64 machine with AVX2: the numerical code paths a notebook kernel uses.

``make figures`` on another machine changed round-off digits in the notes and a few pixels of the
chapter 5 figures, though every seed and thread count was the same. The cause is code that numpy
and OpenBLAS choose at run time by the CPU's instruction sets:

* numpy dispatches float64 ``exp``, ``log``, ``arctan2``, ``tan``, ``expm1``, ``log1p``, ... to
  AVX-512 implementations (Intel SVML) where the CPU has AVX-512, and to others elsewhere; their
  last bit differs (measured: ``NPY_DISABLE_CPU_FEATURES`` on this AVX-512 machine moves the
  chapter 5 Phase II intervention states at 1e-16, hence the fitted ``mu_hat``, hence the contour
  levels of Fig. 5.2 and 5.5);
* OpenBLAS picks its matrix kernels by CPU model (SkylakeX vs Haswell or Zen): ``solve``,
  ``eigvalsh`` and products differ in the last bit (measured with ``OPENBLAS_CORETYPE``).

XLA:CPU gave identical bits with ``--xla_cpu_max_isa=AVX2`` and by default (AVX-512) for the HJ
solver and dense products, so it is left as it is. :func:`portable_env` names the variables that
pin numpy to its AVX2 code (no AVX-512 dispatch) and OpenBLAS to its Haswell kernels on any
x86-64 CPU with AVX2 and FMA; the notebook runner starts every kernel with them, so every such
machine computes the same bits. Values set in the environment already win; other CPUs (no AVX2,
ARM) are left as they are.
"""

import os
import platform

NUMPY_ABOVE_AVX2 = ("X86_V4", "AVX512", "AMX")   # numpy dispatch targets beyond x86-64-v3 (prefixes)
OPENBLAS_CORE = "Haswell"


def _numpy_cpu():
    """numpy's ``(features, dispatch targets)`` of this machine, or None where numpy does not say."""
    try:
        from numpy._core import _multiarray_umath as umath
    except ImportError:  # numpy < 2
        try:
            from numpy.core import _multiarray_umath as umath
        except ImportError:
            return None
    features, targets = getattr(umath, "__cpu_features__", None), getattr(umath, "__cpu_dispatch__", None)
    return (features, list(targets)) if features is not None and targets is not None else None


def portable_env(environ=os.environ):
    """Environment variables (not already in ``environ``) that pin numpy's dispatch and OpenBLAS's
    kernels to x86-64 with AVX2 (module docstring); empty on other CPUs."""
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return {}
    cpu = _numpy_cpu()
    if cpu is None or not (cpu[0].get("AVX2") and cpu[0].get("FMA3")):
        return {}
    pinned = {"NPY_DISABLE_CPU_FEATURES": " ".join(t for t in cpu[1] if t.startswith(NUMPY_ABOVE_AVX2)),
              "OPENBLAS_CORETYPE": OPENBLAS_CORE}
    return {name: value for name, value in pinned.items() if value and name not in environ}
