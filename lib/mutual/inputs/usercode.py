"""A user's own function named as ``"module:function"`` in an input file (a system file's ``system``).

Naming a module RUNS its code: importing it executes the module, whatever it does. So the lookup is
plain and said in the output (:attr:`UserFunction.file`): ``module.py`` (or the package ``module/``) in
the folder of the file that names it first -- read from that file, whatever else is loaded under the same
name --, then an installed module of that name. Nothing else on the path is searched before the installed
modules; while the user's module is imported its own folder is on the path, so that it can import its
neighbours.

A failure is a ValueError naming the input, the module, the file and the function -- never a raw
traceback, and never the end of the run: an exception or ``sys.exit`` at import
(:func:`load_function`) or inside the function (:func:`call`) included. What the module prints while
it is imported goes to stderr, so that a ``--json`` answer on stdout stays one JSON object.
"""

import contextlib
import hashlib
import importlib
import importlib.util
import sys
import traceback
from dataclasses import dataclass
from pathlib import Path

__all__ = ["UserFunction", "call", "load_function"]


@dataclass(frozen=True, eq=False)
class UserFunction:
    """A loaded ``module:function``: the ``function``, its ``spec`` and the ``file`` its module was read from."""
    function: object
    spec: str
    file: str

    def __repr__(self):
        return f"UserFunction({self.spec!r} from {self.file})"


def _local_file(folder, module):
    """The file of ``module`` in ``folder`` (``a.py``, ``a/__init__.py``; for ``a.b``, ``a/b.py`` or
    ``a/b/__init__.py``), or None."""
    if folder is None:
        return None
    base = Path(folder).joinpath(*module.split("."))
    return next((p.resolve() for p in (base.with_suffix(".py"), base / "__init__.py") if p.is_file()), None)


def _failure(err, file):
    """``ExceptionType: message (line L of FILE)`` for an exception raised by the user's code."""
    lines = [f.lineno for f in traceback.extract_tb(err.__traceback__) if file and Path(f.filename) == Path(file)]
    at = f" at line {lines[-1]} of {file}" if lines else ""
    if isinstance(err, SystemExit):
        return f"called sys.exit({err.code!r}){at}"
    text = " ".join(str(err).split()) or "(no message)"
    return f"raised {type(err).__name__}: {text[:300]}{at}"


def _import(module, local, folder):
    """Import ``module``: the installed one, or -- when ``local`` is its file in ``folder`` -- that file, under a
    name of its own (``mutual_user_<name>_<digest of its path and time>``), so that two folders' ``dynamics.py``
    never stand for each other and an edited file is read again. ``folder`` is first on the path meanwhile."""
    if local is None:
        return importlib.import_module(module)
    top, _, rest = module.partition(".")
    top_file = Path(folder) / f"{top}.py"
    top_file = top_file if top_file.is_file() else Path(folder) / top / "__init__.py"
    digest = hashlib.sha1(f"{top_file.resolve()}:{top_file.stat().st_mtime_ns}".encode()).hexdigest()[:12]
    name = f"mutual_user_{top}_{digest}"
    sys.path.insert(0, str(folder))
    try:
        if name not in sys.modules:
            spec = importlib.util.spec_from_file_location(
                name, top_file, submodule_search_locations=[str(top_file.parent)] if top_file.name == "__init__.py"
                else None)
            loaded = importlib.util.module_from_spec(spec)
            sys.modules[name] = loaded
            try:
                spec.loader.exec_module(loaded)
            except BaseException:
                del sys.modules[name]
                raise
        return importlib.import_module(f"{name}.{rest}") if rest else sys.modules[name]
    finally:
        with contextlib.suppress(ValueError):
            sys.path.remove(str(folder))


def load_function(spec, folder=None, where="system"):
    """The function named by ``spec`` (``"module:function"``), looked up as the module docstring says;
    ``folder``: the folder of the file naming it; ``where``: how errors name the input (``"FILE: key 'system'"``)."""
    module, _, name = spec.partition(":")
    if not module or not name:
        raise ValueError(f"{where}: {spec!r} is not 'module:function'")
    local = _local_file(folder, module)
    file = str(local) if local is not None else None
    if file is None:
        try:
            found = importlib.util.find_spec(module)
        except (ImportError, ValueError):
            found = None
        if found is None:
            looked = f"{Path(folder) / (module + '.py')} nor " if folder is not None else ""
            raise ValueError(f"{where}: cannot import module {module!r} of {spec!r} (there is no {looked}installed "
                             f"module {module!r})")
        file = found.origin or module
    try:
        with contextlib.redirect_stdout(sys.stderr):
            loaded = _import(module, local, folder)
    except (Exception, SystemExit) as err:      # an interrupt or a termination is not the module's failure
        raise ValueError(f"{where}: importing module {module!r} ({file}) {_failure(err, file)}") from None
    function = getattr(loaded, name, None)
    if not callable(function):
        raise ValueError(f"{where}: module {module!r} has no function {name!r} (in {file})")
    return UserFunction(function, spec, file)


def call(user, args=(), kwargs=None, where=None):
    """``user.function(*args, **kwargs)``; an exception or ``sys.exit`` inside it becomes a ValueError naming the
    function and its file (and the line where it was raised); ``where``: what the message starts with."""
    try:
        return user.function(*args, **(kwargs or {}))
    except (Exception, SystemExit) as err:      # an interrupt or a termination is not the function's failure
        raise ValueError(f"{where + ': ' if where else ''}{user.spec} ({user.file}) {_failure(err, user.file)}") \
            from None
