"""Read, from a notebook's code, what it reports to the reproduction report.

:class:`NotebookCode` parses the code cells with :mod:`ast` and finds the claims each
``write_results(notebook, {claim_id: {"value": ..., "computed_by": ..., "note": ...}})`` call
reports (also through a dict bound to a name, ``**`` merges and a filtering dict comprehension),
whether a value's expression is a *literal* (a constant, a name bound only to constants or to the
parameters cell, or arithmetic and numpy/builtin conversions of those), and whether the notebook
refers to a given library object. ``tests/notebooks/test_claims.py`` applies it to every notebook.
"""

import ast
import importlib
import math
import re
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import nbformat

from .results import import_dotted

# calls that only convert or combine what they are given: literal in, literal out
_PURE_BUILTINS = {"bool", "int", "float", "str", "round", "abs", "min", "max", "sum", "len", "tuple", "list",
                  "dict", "set", "sorted", "complex", "range", "zip", "enumerate", "reversed"}
_PURE_MODULES = ("numpy", "math")
_MAGIC = re.compile(r"^(\s*)[%!]")
_CLOSE = {"isclose", "allclose", "array_equal"}


class Unresolved(ValueError):
    """The claims a ``write_results`` call reports cannot be read from the code."""


@dataclass
class Reported:
    """One claim as a notebook's code reports it; ``generated`` when its id is computed (an f-string key
    of a comprehension), in which case ``claim`` is the key's source."""

    claim: str
    value: ast.AST
    computed_by: ast.AST | None
    note: ast.AST | None
    cell: int  # number of the code cell with the write_results call (1-based)
    generated: bool = False

    @property
    def source(self):
        return ast.unparse(self.value)


def _without_magics(source):
    return "\n".join(_MAGIC.sub(r"\1pass  # ", line) for line in source.splitlines())


def _element(container, index):
    """A node standing for one element of ``container`` (None stays None)."""
    return None if container is None else ast.Subscript(value=container, slice=ast.Constant(index), ctx=ast.Load())


def _key(node):
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


class NotebookCode:
    """The code cells of the notebook at ``path``, parsed, with every name's bindings."""

    def __init__(self, path):
        self.path = Path(path)
        nb = nbformat.read(str(path), as_version=4)
        self.cells, self.parameters = [], set()
        self.bindings = defaultdict(list)   # name -> value nodes (None: bound to something not literal)
        self.items = defaultdict(list)      # name -> (key node, value node) from name[key] = value
        self.updates = defaultdict(list)    # name -> argument nodes of name.update(...)
        self.mutations = defaultdict(list)  # name -> nodes that change it in place (x[k] = v, x.append(v))
        self.imports = {}                   # name -> dotted path it was imported as
        code = [c for c in nb.cells if c.cell_type == "code"]
        for number, cell in enumerate(code, 1):
            tree = ast.parse(_without_magics(cell.source), filename=f"{self.path.name}, code cell {number}")
            self.cells.append((number, tree))
            if "parameters" in cell.metadata.get("tags", []):
                self.parameters |= {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)
                                    and isinstance(n.ctx, ast.Store)}
            for node in ast.walk(tree):
                self._collect(node)

    # -- bindings ------------------------------------------------------------------------------
    def _bind(self, target, value):
        if isinstance(target, ast.Name):
            self.bindings[target.id].append(value)
        elif isinstance(target, (ast.Tuple, ast.List)):
            same = isinstance(value, (ast.Tuple, ast.List)) and len(value.elts) == len(target.elts)
            for i, elt in enumerate(target.elts):
                self._bind(elt, value.elts[i] if same else _element(value, i))
        elif isinstance(target, ast.Starred):
            self._bind(target.value, None)
        elif isinstance(target, ast.Subscript) and isinstance(target.value, ast.Name):
            self.items[target.value.id].append((target.slice, value))
            self.mutations[target.value.id] += [target.slice, value]

    def _collect(self, node):
        if isinstance(node, ast.Assign):
            for target in node.targets:
                self._bind(target, node.value)
        elif isinstance(node, (ast.AnnAssign, ast.NamedExpr)) and node.value is not None:
            self._bind(node.target, node.value)
        elif isinstance(node, ast.AugAssign) and isinstance(node.target, ast.Subscript):
            self._bind(node.target, ast.BinOp(left=node.target, op=node.op, right=node.value))
        elif isinstance(node, ast.AugAssign):
            self._bind(node.target, ast.BinOp(left=ast.Name(id=getattr(node.target, "id", "_"), ctx=ast.Load()),
                                              op=node.op, right=node.value))
        elif isinstance(node, (ast.For, ast.AsyncFor, ast.comprehension)):
            self._bind(node.target, _element(node.iter, 0))  # literal only if what it runs over is
        elif isinstance(node, ast.withitem) and node.optional_vars is not None:
            self._bind(node.optional_vars, None)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            for alias in node.names:
                if alias.name == "*":
                    continue
                name = alias.asname or alias.name.split(".")[0]
                if isinstance(node, ast.ImportFrom):
                    self.imports[name] = f"{node.module}.{alias.name}"
                else:
                    self.imports[name] = alias.name if alias.asname else name
                self.bindings[name].append(None)
        elif isinstance(node, ast.arguments):
            for arg in node.posonlyargs + node.args + node.kwonlyargs + [node.vararg, node.kwarg]:
                if arg is not None:
                    self.bindings[arg.arg].append(None)
        elif isinstance(node, ast.ExceptHandler) and node.name:
            self.bindings[node.name].append(None)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and isinstance(node.func.value, ast.Name):
            self.mutations[node.func.value.id] += node.args + [k.value for k in node.keywords]
            if node.func.attr == "update":
                self.updates[node.func.value.id] += node.args

    # -- literals ------------------------------------------------------------------------------
    def is_literal(self, node, _visiting=frozenset()):
        """Whether ``node`` only restates constants typed into the notebook (or its parameters)."""
        lit = lambda n: n is None or self.is_literal(n, _visiting)  # noqa: E731
        if isinstance(node, ast.Constant):
            return True
        if isinstance(node, ast.Name):
            if node.id in _visiting:
                return True
            binds, inner = self.bindings.get(node.id), _visiting | {node.id}
            return (bool(binds) and all(b is not None and self.is_literal(b, inner) for b in binds)
                    and all(self.is_literal(m, inner) for m in self.mutations.get(node.id, [])))
        if isinstance(node, (ast.List, ast.Tuple, ast.Set)):
            return all(lit(e) for e in node.elts)
        if isinstance(node, ast.Starred):
            return lit(node.value)
        if isinstance(node, ast.Dict):
            return all(lit(k) for k in node.keys) and all(lit(v) for v in node.values)
        if isinstance(node, ast.JoinedStr):
            return all(lit(v) for v in node.values)
        if isinstance(node, ast.FormattedValue):
            return lit(node.value)
        if isinstance(node, ast.UnaryOp):
            return lit(node.operand)
        if isinstance(node, ast.BinOp):
            return lit(node.left) and lit(node.right)
        if isinstance(node, ast.BoolOp):
            return all(lit(v) for v in node.values)
        if isinstance(node, ast.Compare):
            return lit(node.left) and all(lit(c) for c in node.comparators)
        if isinstance(node, ast.IfExp):
            same = (isinstance(node.body, ast.Constant) and isinstance(node.orelse, ast.Constant)
                    and node.body.value == node.orelse.value)
            return same or (lit(node.test) and lit(node.body) and lit(node.orelse))
        if isinstance(node, ast.Subscript):
            return lit(node.value) and lit(node.slice)
        if isinstance(node, ast.Slice):
            return lit(node.lower) and lit(node.upper) and lit(node.step)
        if isinstance(node, ast.Call):
            return (self._pure(node.func) and all(lit(a) for a in node.args)
                    and all(lit(k.value) for k in node.keywords))
        return False

    def _pure(self, func):
        if isinstance(func, ast.Name):
            return func.id in _PURE_BUILTINS and func.id not in self.bindings
        root = func
        while isinstance(root, ast.Attribute):
            root = root.value
        return isinstance(root, ast.Name) and self.imports.get(root.id, "").split(".")[0] in _PURE_MODULES

    # -- what write_results reports -------------------------------------------------------------
    def reported(self):
        """Every claim the notebook's ``write_results`` calls report, as :class:`Reported`."""
        found = []
        for number, tree in self.cells:
            for node in ast.walk(tree):
                if not (isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", None))
                        == "write_results"):
                    continue
                args = list(node.args) + [k.value for k in node.keywords if k.arg in ("notebook", "claims")]
                if len(args) < 2:
                    raise Unresolved(f"{self.path.name}, code cell {number}: write_results needs the notebook's "
                                     "name and the claims")
                for claim, entry in self._entries(args[1], number, set()):
                    value, computed_by, note = self._fields(entry)
                    generated = not isinstance(claim, str)
                    found.append(Reported(ast.unparse(claim) if generated else claim, value, computed_by, note,
                                          number, generated))
        return found

    def _entries(self, node, cell, seen):
        where = f"{self.path.name}, code cell {cell}"
        if isinstance(node, ast.Dict):
            out = []
            for key, value in zip(node.keys, node.values):
                if key is None:
                    out += self._entries(value, cell, seen)
                else:
                    out.append((_key(key) or key, value))
            return out
        if isinstance(node, ast.Name) and node.id not in seen:
            seen = seen | {node.id}
            binds = self.bindings.get(node.id, [])
            if not binds or any(b is None for b in binds):
                raise Unresolved(f"{where}: cannot read the claims bound to {node.id!r}; write them as a dict literal")
            out = [e for b in binds for e in self._entries(b, cell, seen)]
            out += [e for u in self.updates.get(node.id, []) for e in self._entries(u, cell, seen)]
            out += [(_key(key) or key, value) for key, value in self.items.get(node.id, [])]
            return out
        if isinstance(node, ast.DictComp):
            it = node.generators[0].iter
            if (len(node.generators) == 1 and isinstance(it, ast.Call) and isinstance(it.func, ast.Attribute)
                    and it.func.attr == "items"):
                return self._entries(it.func.value, cell, seen)  # a filtered copy of another dict
            return [(node.key, node.value)]  # claims generated by the comprehension
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.BitOr):
            return self._entries(node.left, cell, seen) + self._entries(node.right, cell, seen)
        if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "dict":
            out = [e for a in node.args for e in self._entries(a, cell, seen)]
            return out + [(k.arg, k.value) for k in node.keywords if k.arg] + \
                [e for k in node.keywords if not k.arg for e in self._entries(k.value, cell, seen)]
        raise Unresolved(f"{where}: cannot read the claims from {ast.unparse(node)[:80]!r}; write them as a dict literal")

    def _fields(self, entry):
        """(value, computed_by, note) nodes of one entry (a dict literal, or a name bound to one)."""
        node = entry
        if isinstance(node, ast.Name):
            binds = self.bindings.get(node.id, [])
            if len(binds) == 1 and isinstance(binds[0], ast.Dict):
                node = binds[0]
        if isinstance(node, ast.Dict):
            fields = {k.value: v for k, v in zip(node.keys, node.values) if isinstance(k, ast.Constant)}
            if "value" in fields:
                return fields["value"], fields.get("computed_by"), fields.get("note")
        return entry, None, None

    # -- what the notebook calls ----------------------------------------------------------------
    def references(self, target):
        """Whether the notebook refers to the library object ``target`` (called, or passed on), through
        its imports; for a method ``Class.method``: refers to ``Class`` and to an attribute ``method``."""
        objects, attributes = self._referenced()
        target = getattr(target, "__wrapped__", target)
        if any(obj is target for obj in objects):
            return True
        owner_name, _, method = getattr(target, "__qualname__", "").rpartition(".")
        module = importlib.import_module(target.__module__) if getattr(target, "__module__", None) else None
        owner = getattr(module, owner_name, None) if owner_name and "<" not in owner_name else None
        return isinstance(owner, type) and any(o is owner for o in objects) and method in attributes

    def _referenced(self):
        if not hasattr(self, "_refs"):
            objects, attributes, cache = [], set(), {}
            for _, tree in self.cells:
                for node in ast.walk(tree):
                    if isinstance(node, ast.Attribute):
                        attributes.add(node.attr)
                    chain = self._chain(node)
                    if chain and chain[0] in self.imports and chain not in cache:
                        cache[chain] = import_dotted(".".join([self.imports[chain[0]], *chain[1:]]))[0]
                        if cache[chain] is not None:
                            objects.append(getattr(cache[chain], "__wrapped__", cache[chain]))
            self._refs = objects, attributes
        return self._refs

    @staticmethod
    def _chain(node):
        names = []
        while isinstance(node, ast.Attribute):
            names.append(node.attr)
            node = node.value
        if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Load):
            return tuple([node.id] + names[::-1])
        return None

    # -- echoes of typed-in settings -----------------------------------------------------------
    def names_feeding(self, node):
        """Every name whose value flows into ``node``: the names it uses and, transitively, the names
        their bindings and in-place changes use."""
        seen, stack = set(), [node]
        while stack:
            current = stack.pop()
            if current is None:
                continue
            for sub in ast.walk(current):
                if isinstance(sub, ast.Name) and sub.id not in seen:
                    seen.add(sub.id)
                    stack.extend(b for b in self.bindings.get(sub.id, []) if b is not None)
                    if sub.id not in self.imports:  # st.f(x) does not change the module st
                        stack.extend(self.mutations.get(sub.id, []))
        return seen

    def _comparisons(self, node):
        """The operands of the comparisons (``a == b``, ``np.isclose(a, b)``) and differences or ratios
        (``abs(a - b) < tol``) that decide ``node``'s value, following names to what they are bound to."""
        found, seen, stack = [], set(), [node]
        while stack:
            current = stack.pop()
            for sub in ast.walk(current):
                if isinstance(sub, ast.Compare):
                    found.append([sub.left] + list(sub.comparators))
                elif isinstance(sub, ast.BinOp) and isinstance(sub.op, (ast.Sub, ast.Div)):
                    found.append([sub.left, sub.right])  # abs(a - b) < tol, a / b > 0.99
                elif isinstance(sub, ast.Call) and getattr(sub.func, "attr", getattr(sub.func, "id", "")) in _CLOSE:
                    found.append(list(sub.args[:2]))
                elif isinstance(sub, ast.Name) and sub.id not in seen:
                    seen.add(sub.id)
                    stack.extend(b for b in self.bindings.get(sub.id, []) if b is not None)
        return found

    def echo(self, reported, thesis_value, rule, value):
        """Why ``reported``'s ``value`` only gives back a setting the notebook typed in, or None.

        A number is an echo when it equals (or, within the claim's tolerance -- 1% for a bound --
        nearly equals) a named constant of the notebook that equals the thesis value and feeds the
        value's computation (exact equality counts without the data flow). A boolean is an echo when
        it compares a quantity with a named constant that also feeds that quantity (e.g. a fit's
        ``w_max == example_w_max`` where ``example_w_max`` generated the data)."""
        constants = self.scalar_constants()
        if isinstance(value, bool):
            for operands in self._comparisons(reported.value):
                for i, operand in enumerate(operands):
                    if not self.is_literal(operand):  # the setting itself (or constant arithmetic of it)
                        continue
                    typed = [n.id for n in ast.walk(operand) if isinstance(n, ast.Name) and n.id in constants]
                    others = set().union(*(self.names_feeding(o) for j, o in enumerate(operands) if j != i))
                    for name in typed:
                        if name in others:
                            return (f"it compares a quantity with {name} = {constants[name]}, a setting the notebook "
                                    f"typed in that also produced that quantity (`{ast.unparse(operand)[:40]}`)")
            return None
        if not isinstance(value, (int, float)):
            return None
        try:
            thesis = float(thesis_value)
        except ValueError:
            return None
        kind, _, tol = rule.partition(":")
        feeding = None
        for name, c in sorted(constants.items()):
            if c == 0 or not math.isclose(c, thesis, rel_tol=1e-9, abs_tol=1e-12):
                continue  # a zero (an error, a rate) is a result, never a setting coming back
            if value == c and not float(value).is_integer():
                return f"the value {value} is the thesis value and the setting {name} = {c} the notebook typed in"
            width = float(tol) * (abs(c) if kind == "rel" else 1) if kind in ("abs", "rel") else 0.01 * abs(c)
            if abs(value - c) <= max(width, 1e-12):
                feeding = self.names_feeding(reported.value) if feeding is None else feeding
                if name in feeding:
                    return (f"the value {value} nearly equals the setting {name} = {c} (the thesis value), which "
                            "feeds its computation: the input coming back")
        return None

    def scalar_constants(self):
        """``{name: number}`` for names bound only to one numeric constant (parameters and settings)."""
        out = {}
        for name, binds in self.bindings.items():
            if len(binds) == 1 and isinstance(binds[0], ast.Constant) and type(binds[0].value) in (int, float):
                out[name] = binds[0].value
        return out
