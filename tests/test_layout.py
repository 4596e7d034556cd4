"""The package's architecture, read from the source (AST) without importing it: the thrusts apart, each
reached by the others, the command line and the report only through its face (the names its package lists in
``__all__``), the machinery never imported by the algorithms, no import circles, no module too long to hold
in mind."""

import ast
import json
from pathlib import Path

import pytest

import mutual

PACKAGE = Path(mutual.__file__).parent
ROOT = PACKAGE.parents[1]
MODULES = sorted(PACKAGE.rglob("*.py"))
ALGORITHMS = ("constraints", "supervision", "study", "motion", "cycle")
#: packages reached from outside only through their face: the thrusts (continuous/ is constraints' extension)
#: and the readers of users' files
FACES = ("mutual.constraints", "mutual.constraints.continuous", "mutual.supervision", "mutual.study", "mutual.motion",
         "mutual.cycle", "mutual.inputs")
MAX_LINES = 420


def _name(path):
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imported(path):
    """``(module, name, line)`` for every import of a mutual module in ``path`` (anywhere in its body, absolute
    or relative); ``name`` is None for ``import mutual.x``."""
    here = _name(path).split(".")
    package = here if path.name == "__init__.py" else here[:-1]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            yield from ((a.name, None, node.lineno) for a in node.names if a.name.startswith("mutual"))
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            if module.startswith("mutual"):
                yield from ((module, a.name, node.lineno) for a in node.names)


def _imports(path):
    """Every mutual module that ``path`` imports."""
    found = set()
    for module, name, _ in _imported(path):
        found |= {module} | ({f"{module}.{name}"} if name else set())
    known = {_name(p) for p in MODULES}
    return {m for m in found if m in known} - {_name(path)}


GRAPH = {_name(p): _imports(p) for p in MODULES}


def _face(package):
    """``{name: module}`` of a package's face: what ``__all__`` lists, with the submodule each name comes from
    (imported at the top or named in the ``lazy_names`` table read on first use)."""
    tree = ast.parse((PACKAGE.parent.joinpath(*package.split(".")) / "__init__.py").read_text())
    listed, source = [], {}
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
            listed = [e.value for e in node.value.elts]
        elif isinstance(node, ast.ImportFrom) and node.level == 1 and node.module:
            source |= {a.asname or a.name: node.module for a in node.names}
    for node in ast.walk(tree):
        if isinstance(node, ast.Dict) and node.keys and all(isinstance(k, ast.Constant) for k in node.keys):
            source |= {k.value: v.value for k, v in zip(node.keys, node.values) if isinstance(v, ast.Constant)}
    return {name: source.get(name) for name in listed}


FACE = {face: _face(face) for face in FACES}


def _face_of(module):
    return "mutual.constraints.continuous" if module.startswith("mutual.constraints.continuous") else \
        ".".join(module.split(".")[:2])


def test_the_thrusts_and_the_machinery_are_subpackages():
    packages = sorted(p.name for p in PACKAGE.iterdir() if (p / "__init__.py").exists())
    assert packages == sorted(ALGORITHMS + ("compendium", "cli", "inputs"))


@pytest.mark.parametrize("name", [n for n in GRAPH if n.split(".")[1:2] and n.split(".")[1] in ALGORITHMS])
def test_algorithms_never_import_the_machinery(name):
    assert not [m for m in GRAPH[name] if m.startswith("mutual.compendium")], f"{name} imports the compendium"


@pytest.mark.parametrize("path", [p for p in MODULES if _name(p) != "mutual"], ids=_name)
def test_other_thrusts_are_reached_only_through_their_face(path):
    """A module of one thrust (or of cli/, compendium/, a top-level module) imports from another thrust, or from
    inputs/, only names its face lists in ``__all__``: ``from mutual.supervision import fit_supervisor``, never a
    submodule or a private helper."""
    here = _name(path).split(".")[1]
    wrong = []
    for module, name, line in _imported(path):
        there = module.split(".")[1] if module.count(".") else None
        if there not in ALGORITHMS + ("inputs",) or there == here:
            continue
        face = _face_of(module)
        if module != face or name is None:
            wrong.append(f"line {line}: {module}{'.' + name if name else ''} is not the face {face}")
        elif name not in FACE[face]:
            wrong.append(f"line {line}: {name} is not in {face}.__all__")
    assert not wrong, f"{_name(path)}: " + "; ".join(wrong)


@pytest.mark.parametrize("face", FACES)
def test_a_face_names_where_each_name_comes_from(face):
    """Every name of ``__all__`` is imported at the top of the package or read on first use from a named module."""
    assert FACE[face] and not [n for n, module in FACE[face].items() if module is None], FACE[face]


def _computed_by():
    """The ``computed_by`` strings of the report: the notebooks' results entries (``"computed_by": "mutual...."``)
    and data/paper_claims.csv's column of that name, if it has one."""
    found = set()
    for notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
        for cell in json.loads(notebook.read_text())["cells"]:
            if cell["cell_type"] != "code":
                continue
            for node in ast.walk(ast.parse("".join(cell["source"]))):
                if isinstance(node, ast.Dict):
                    found |= {v.value for k, v in zip(node.keys, node.values) if isinstance(k, ast.Constant)
                              and k.value == "computed_by" and isinstance(v, ast.Constant)}
    claims = ROOT / "data" / "paper_claims.csv"
    if claims.exists():
        import csv
        with claims.open(newline="") as f:
            found |= {row["computed_by"] for row in csv.DictReader(f) if row.get("computed_by")}
    return sorted(found)


def test_the_report_names_computations():
    assert len(_computed_by()) > 50


@pytest.mark.parametrize("dotted", _computed_by())
def test_the_reports_computations_are_public_names(dotted):
    """``mutual.<package>.<module>.<name>`` with ``name`` in the face of a package on that path (the thrust's,
    or one of its subpackages'), coming from that module: a reader finds each computation in the public API."""
    parts = dotted.split(".")
    module, name = ".".join(parts[:-1]), parts[-1]
    faces = [".".join(parts[:i]) for i in range(2, len(parts))
             if (PACKAGE.parent.joinpath(*parts[:i]) / "__init__.py").exists()]
    assert any(name in _face(face) and module in (face, f"{face}.{_face(face)[name]}") for face in faces), \
        f"{dotted}: add {name} to the __all__ of {' or '.join(faces)}"


def test_no_import_circles():
    """Depth-first search over module imports (a package's ``__init__`` re-exports are edges too,
    except a package to its own submodules, which is how Python loads it)."""
    def edges(n):
        return {m for m in GRAPH[n] if not (m.startswith(n + ".") and n != "mutual")}
    state, stack = {}, []

    def visit(n):
        state[n] = "open"
        stack.append(n)
        for m in edges(n):
            if state.get(m) == "open":
                pytest.fail("import circle: " + " -> ".join(stack[stack.index(m):] + [m]))
            if m not in state:
                visit(m)
        stack.pop()
        state[n] = "done"

    for n in sorted(GRAPH):
        if n not in state:
            visit(n)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: _name(p))
def test_modules_stay_short(path):
    lines = len(path.read_text().splitlines())
    assert lines <= MAX_LINES, f"{_name(path)} has {lines} lines: split it by idea"


@pytest.mark.parametrize("package", ALGORITHMS + ("constraints.continuous",))
def test_each_subpackage_states_its_public_api(package):
    module = __import__(f"mutual.{package}", fromlist=["__all__"])
    assert module.__all__ and all(hasattr(module, n) for n in module.__all__)


TESTS = ROOT / "tests"
#: test folders that mirror no package folder (docs/ARCHITECTURE.md, "Tests")
UNMIRRORED = ("notebooks", "browser", "helpers", "data")
#: files that test a whole folder's invariants rather than one module
ACROSS = ("test_properties.py", "test_layout.py")
#: tests/compendium/ files that check a file or make target of the repository rather than a module: what they check
ARTEFACTS = {"test_bench_runner.py": "bench/run.py", "test_binder.py": "binder", "test_book.py": "book/build.py",
             "test_citation.py": "CITATION.cff", "test_install.py": "installer.lock", "test_lab.py": "Makefile",
             "test_peers_lock.py": "bench/peers"}


def _mirrored_tests():
    return sorted(p for p in TESTS.rglob("test_*.py") if p.relative_to(TESTS).parts[0] not in UNMIRRORED
                  and p.name not in ACROSS and not (p.parent.name == "compendium" and p.name in ARTEFACTS))


@pytest.mark.parametrize("path", _mirrored_tests(), ids=lambda p: str(p.relative_to(TESTS)))
def test_each_test_file_is_named_after_the_module_it_tests(path):
    """tests/<package>/test_<module>[_<aspect>].py tests lib/mutual/<package>/<module>.py, and
    test_<package>[_<aspect>].py the package as a whole (tests/cli/test_cli.py); a subpackage's tests live in its own
    folder: a contributor finds a module's tests, and a new test's file, from the module's name alone."""
    folder = PACKAGE.joinpath(*path.parent.relative_to(TESTS).parts)
    words = path.stem.removeprefix("test_").split("_")
    prefixes = ["_".join(words[:k]) for k in range(len(words), 0, -1)]
    assert folder.is_dir(), f"{path.relative_to(ROOT)}: no package folder {folder.relative_to(ROOT)} to mirror"
    named = any((folder / f"{p}.py").is_file() or p == folder.name for p in prefixes) or \
        (folder / prefixes[0] / "__init__.py").is_file()
    assert named, (f"{path.relative_to(ROOT)}: its name starts with no module of {folder.relative_to(ROOT)}; name it "
                   "test_<module>.py (or test_<module>_<aspect>.py) after the module it tests, in the folder that "
                   "mirrors the module's package")


@pytest.mark.parametrize("name, artefact", sorted(ARTEFACTS.items()))
def test_the_compendium_tests_of_repository_files_name_files_that_exist(name, artefact):
    assert (TESTS / "compendium" / name).is_file() and (ROOT / artefact).exists(), (name, artefact)
