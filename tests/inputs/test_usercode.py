"""A user's "module:function" (mutual.inputs.usercode): every way it can fail -- at import, when called,
sys.exit included -- is a ValueError naming the module, its file and the line, and the lookup is the
documented one: the file's own folder first, then installed modules, nothing else."""

import importlib.util
import os
import sys
import textwrap

import pytest

from mutual.inputs import call, load_function

MODULES = [  # (case, module source, function name, phrases of the error at import or at the call)
    ("sys.exit(0) at import", "import sys\nsys.exit(0)\n", "f", ["importing module", "called sys.exit(0) at line 2 of"]),
    ("sys.exit('bye') at import", "import sys\nsys.exit('bye')\n", "f", ["called sys.exit('bye') at line 2 of"]),
    ("a raise at import", "x = 1\nraise RuntimeError('no licence')\n", "f",
     ["importing module", "raised RuntimeError: no licence at line 2 of"]),
    ("a syntax error", "def f(x, u):\n    return x +\n", "f", ["raised SyntaxError"]),
    ("a missing dependency", "import not_installed_anywhere\n", "f", ["raised ModuleNotFoundError"]),
    ("no such function", "def g(x, u):\n    return x\n", "f", ["has no function 'f'"]),
    ("not a function", "f = 3\n", "f", ["has no function 'f'"]),
    ("a raise in the call", "def f(x, u):\n    y = 1\n    return [][y]\n", "f",
     ["raised IndexError: list index out of range at line 3 of"]),
    ("sys.exit in the call", "import sys\ndef f(x, u):\n    sys.exit(3)\n", "f", ["called sys.exit(3) at line 3 of"]),
]


@pytest.mark.parametrize("case, source, name, phrases", MODULES, ids=[c[0] for c in MODULES])
def test_failures_name_the_module_file_and_line(case, source, name, phrases, tmp_path):
    module = f"user_{abs(hash(case)):x}"
    (tmp_path / f"{module}.py").write_text(source)
    with pytest.raises(ValueError) as err:
        call(load_function(f"{module}:{name}", tmp_path, "s.toml: key 'system'"), (1, 2), None, "system")
    message = str(err.value)
    assert str(tmp_path / f"{module}.py") in message and all(p in message for p in phrases), message
    assert message.startswith(("s.toml: key 'system'", "system: ")), message


class _Stop(BaseException):
    """What the command line raises on SIGTERM (mutual.cli.common.Terminated): not an exception of the user's code."""


@pytest.mark.parametrize("where", ["import", "call"])
def test_an_interrupt_or_termination_inside_the_users_code_is_not_blamed_on_it(where, tmp_path, monkeypatch):
    """A SIGTERM (a BaseException of the command line) or Ctrl-C while the module loads or runs goes through
    unchanged: the run ends as terminated, never as 'the system file's dynamics raised Terminated'."""
    stop = "raise STOP()\n" if where == "import" else "def f(x, u):\n    raise STOP()\n"
    for kind in (_Stop, KeyboardInterrupt):
        module = f"stops_{where}_{kind.__name__}"
        (tmp_path / f"{module}.py").write_text("import builtins\nSTOP = builtins.STOP\n" + stop)
        monkeypatch.setattr("builtins.STOP", kind, raising=False)
        with pytest.raises(kind):
            call(load_function(f"{module}:f", tmp_path, "s.toml: key 'system'"), (1, 2), None, "system")


def test_prints_at_import_go_to_stderr(tmp_path, capsys):
    (tmp_path / "chatty_dynamics.py").write_text("print('hello from the import')\ndef f(x, u):\n    return x\n")
    user = load_function("chatty_dynamics:f", tmp_path)
    out, err = capsys.readouterr()
    assert out == "" and "hello from the import" in err
    assert user.file == str((tmp_path / "chatty_dynamics.py").resolve())


def test_the_files_folder_comes_first_and_nothing_else(tmp_path, monkeypatch):
    """A module beside the file wins over an installed one of the same name that is not loaded yet; a folder
    merely on sys.path is never searched before the installed modules; the folder leaves sys.path again."""
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "local_only_dyn.py").write_text("def f(x, u):\n    return 'local'\n")
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "elsewhere_dyn.py").write_text("def f(x, u):\n    return 'elsewhere'\n")
    before = list(sys.path)
    user = load_function("local_only_dyn:f", tmp_path / "mine")
    assert user.function(0, 0) == "local" and sys.path == before
    with pytest.raises(ValueError, match="there is no .*elsewhere_dyn.py nor installed module 'elsewhere_dyn'"):
        load_function("elsewhere_dyn:f", tmp_path / "mine")


def test_a_local_module_is_read_from_its_file_whatever_else_has_its_name(tmp_path):
    """``json.py`` beside the file is the one named, though Python's json is loaded; two folders' ``dynamics.py``
    are two modules; an edited file is read again."""
    (tmp_path / "json.py").write_text("def f(x, u):\n    return 'local json'\n")
    assert load_function("json:f", tmp_path).function(0, 0) == "local json" and sys.modules["json"].dumps
    for name in ("one", "two"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "dyn_twice.py").write_text(f"def f(x, u):\n    return {name!r}\n")
    assert [load_function("dyn_twice:f", tmp_path / n).function(0, 0) for n in ("one", "two")] == ["one", "two"]
    path = tmp_path / "one" / "dyn_twice.py"
    path.write_text("def f(x, u):\n    return 'edited'\n")
    os.utime(path, ns=(path.stat().st_atime_ns, path.stat().st_mtime_ns + 10 ** 9))
    assert load_function("dyn_twice:f", tmp_path / "one").function(0, 0) == "edited"


def test_a_package_beside_the_file_with_a_submodule(tmp_path):
    (tmp_path / "mydyn").mkdir()
    (tmp_path / "mydyn" / "__init__.py").write_text("from .helpers import SCALE\n")
    (tmp_path / "mydyn" / "helpers.py").write_text("SCALE = 2\n")
    (tmp_path / "mydyn" / "cars.py").write_text("from . import SCALE\ndef f(x, u):\n    return SCALE * x\n")
    assert load_function("mydyn.cars:f", tmp_path).function(3, 0) == 6


def test_an_installed_module_is_found_and_named(tmp_path):
    user = load_function("math:hypot", tmp_path)
    assert user.function(3, 4) == 5 and user.file == importlib.util.find_spec("math").origin
    user = load_function("textwrap:dedent", None)
    assert user.file == textwrap.__file__
