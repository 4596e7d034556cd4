"""The package's architecture: the thrusts apart, the machinery never imported by the algorithms, no import
circles, no module too long to hold in mind."""

import ast
from pathlib import Path

import pytest

import mutual

PACKAGE = Path(mutual.__file__).parent
MODULES = sorted(PACKAGE.rglob("*.py"))
ALGORITHMS = ("constraints", "supervision", "study", "motion", "cycle")
MAX_LINES = 420


def _name(path):
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path):
    """Every mutual module that ``path`` imports, anywhere in its body (absolute or relative)."""
    here = _name(path).split(".")
    package = here if path.name == "__init__.py" else here[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.startswith("mutual")}
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            if module.startswith("mutual"):
                found.add(module)
                found |= {f"{module}.{a.name}" for a in node.names}
    known = {_name(p) for p in MODULES}
    return {m for m in found if m in known} - {_name(path)}


GRAPH = {_name(p): _imports(p) for p in MODULES}


def test_the_thrusts_and_the_machinery_are_subpackages():
    packages = sorted(p.name for p in PACKAGE.iterdir() if (p / "__init__.py").exists())
    assert packages == sorted(ALGORITHMS + ("compendium", "cli"))


@pytest.mark.parametrize("name", [n for n in GRAPH if n.split(".")[1:2] and n.split(".")[1] in ALGORITHMS])
def test_algorithms_never_import_the_machinery(name):
    assert not [m for m in GRAPH[name] if m.startswith("mutual.compendium")], f"{name} imports the compendium"


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


@pytest.mark.parametrize("package", ALGORITHMS)
def test_each_subpackage_states_its_public_api(package):
    module = __import__(f"mutual.{package}", fromlist=["__all__"])
    assert module.__all__ and all(hasattr(module, n) for n in module.__all__)
