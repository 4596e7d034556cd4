"""A user's "module:function" (mutual.inputs.usercode): every way it can fail -- at import, when called,
sys.exit included -- is a ValueError naming the module, its file and the line, and the lookup is the
documented one: the file's own folder first, then installed modules, nothing else."""

import importlib.util
import sys
import textwrap

import pytest

from mutual.inputs import call, load_function

MODULES = [  # (case, module source, function name, phrases of the error at import or at the call)
    ("sys.exit(0) at import", "import sys\nsys.exit(0)\n", "f", ["importing module", "called sys.exit(0)"]),
    ("sys.exit('bye') at import", "import sys\nsys.exit('bye')\n", "f", ["called sys.exit('bye')"]),
    ("a raise at import", "x = 1\nraise RuntimeError('no licence')\n", "f",
     ["importing module", "raised RuntimeError: no licence at line 2 of"]),
    ("a syntax error", "def f(x, u):\n    return x +\n", "f", ["raised SyntaxError"]),
    ("a missing dependency", "import not_installed_anywhere\n", "f", ["raised ModuleNotFoundError"]),
    ("no such function", "def g(x, u):\n    return x\n", "f", ["has no function 'f'"]),
    ("not a function", "f = 3\n", "f", ["has no function 'f'"]),
    ("a raise in the call", "def f(x, u):\n    y = 1\n    return [][y]\n", "f",
     ["raised IndexError: list index out of range at line 3 of"]),
    ("sys.exit in the call", "import sys\ndef f(x, u):\n    sys.exit(3)\n", "f", ["called sys.exit(3)"]),
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


def test_a_local_module_named_like_a_loaded_one_is_refused(tmp_path):
    (tmp_path / "json.py").write_text("def f(x, u):\n    return x\n")
    with pytest.raises(ValueError, match="the name 'json' is taken by a module already loaded from"):
        load_function("json:f", tmp_path)


def test_an_installed_module_is_found_and_named(tmp_path):
    user = load_function("math:hypot", tmp_path)
    assert user.function(3, 4) == 5 and user.file == importlib.util.find_spec("math").origin
    user = load_function("textwrap:dedent", None)
    assert user.file == textwrap.__file__
