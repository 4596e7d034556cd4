"""TOML files of the command line (worlds, legibility specs, system files): one reader and one way of
checking their keys, with errors that name the file and the key: ``FILE: key 'table.key': reason``.

* :func:`read_toml`: the mapping in a file. A UTF-8 byte-order mark (as some Windows editors write) is
  accepted; text that is not UTF-8, or not TOML, or nested deeper than :data:`MAX_DEPTH` arrays and
  tables (Python's TOML parser would run out of stack on 100 000 brackets) is refused naming the file.
* :class:`Keys`: the checked reading of a mapping's keys -- unknown and missing keys, numbers within
  bounds, lists of numbers or names, a choice among words, a sub-table -- each error naming the key.
"""

import codecs
import math
import re
import tomllib
from pathlib import Path

from .values import check_number, number_text, real, shown

__all__ = ["MAX_DEPTH", "Keys", "read_toml"]

MAX_DEPTH = 64
_MISSING = object()
_STRINGS = re.compile(r'"""(?:[^\\]|\\.)*?"""|\'\'\'.*?\'\'\'|"(?:[^"\\\n]|\\.)*"|\'[^\'\n]*\'|#[^\n]*', re.S)


def _depth(text):
    """The deepest nesting of ``[``/``{`` in TOML text outside strings and comments (table headers count 1)."""
    depth = deepest = 0
    for ch in _STRINGS.sub("", text):
        if ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth = max(depth - 1, 0)
    return deepest


def read_toml(path):
    """The mapping in the TOML file ``path``; a ValueError naming the file when it is not valid TOML."""
    path = Path(path)
    data = path.read_bytes()
    try:
        text = data.removeprefix(codecs.BOM_UTF8).decode("utf-8")
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not valid TOML (not UTF-8 text: byte {err.start})") from None
    if text.count("[") + text.count("{") > MAX_DEPTH and _depth(text) > MAX_DEPTH:
        raise ValueError(f"{path}: not valid TOML for mutual (arrays or tables nested more than {MAX_DEPTH} "
                         "deep; no input of mutual needs more than 3)")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"{path}: not valid TOML ({err})") from None


class Keys:
    """A mapping read from a file named ``source``, whose keys are checked on reading; ``prefix``: the table's
    name (``"state."``) in the keys that errors name."""

    def __init__(self, mapping, source, prefix=""):
        self.mapping, self.source, self.prefix = mapping, str(source), prefix
        if not isinstance(mapping, dict):
            where = f"{source}: key {prefix[:-1]!r}: must be a table [{prefix[:-1]}]" if prefix else \
                f"{source}: must be a table of keys"
            raise ValueError(f"{where}, got {type(mapping).__name__}")

    def fail(self, key, reason):
        """Raise ``SOURCE: key 'PREFIX.KEY': reason``."""
        raise ValueError(f"{self.source}: key {self.prefix + key!r}: {reason}")

    def __contains__(self, key):
        return key in self.mapping

    def get(self, key, default=None):
        return self.mapping.get(key, default)

    def known(self, keys, required=(), what="key"):
        """Refuse a key not among ``keys`` (the first, sorted) and a missing ``required`` one."""
        unknown = sorted(k for k in self.mapping if k not in keys)
        if unknown:
            self.fail(unknown[0], f"unknown {what} (known: {', '.join(keys)})")
        for key in required:
            if key not in self.mapping:
                self.fail(key, "missing (required)")
        return self

    def table(self, name, keys=None, required=()):
        """The sub-table ``[name]`` (empty when absent) as :class:`Keys`, its keys checked against ``keys``."""
        value = self.mapping.get(name, {})
        if not isinstance(value, dict):
            self.fail(name, f"must be a table [{self.prefix + name}]")
        table = Keys(value, self.source, f"{self.prefix}{name}.")
        return table.known(keys, required) if keys is not None else table

    def _value(self, key, default):
        if key in self.mapping:
            return self.mapping[key]
        if default is _MISSING:
            self.fail(key, "missing (required)")
        return default

    def number(self, key, low=None, high=None, default=_MISSING, low_open=False, high_open=False, integer=False):
        """A number (an int with ``integer``) within the bounds; ``default`` when absent (else it is required)."""
        value = self._value(key, default)
        if key not in self.mapping and default is not _MISSING:
            return value
        return check_number(f"{self.source}: key {self.prefix + key!r}", value, low, high, low_open, high_open,
                            integer=integer, sep=": ")

    def numbers(self, key, n=None, low=None, default=_MISSING, integer=False, sizes=None, value=_MISSING):
        """A non-empty list of ``n`` numbers (of one of ``sizes``; integers with ``integer``), each >= ``low``;
        ``value``: check this value (an element of a list of lists, say) under the name ``key``."""
        value = self._value(key, default) if value is _MISSING else value
        lengths = sizes or ((n,) if n is not None else None)
        ok = isinstance(value, list) and bool(value) and (lengths is None or len(value) in lengths)
        ok = ok and all(_fits(v, low, integer) for v in value)
        if not ok:
            count = " or ".join(str(s) for s in lengths) + " " if lengths else ""
            noun = "integers" if integer else "numbers"
            bound = f" >= {number_text(low)}" if low is not None else ""
            self.fail(key, f"must be a list of {count}{noun}{bound}, got {shown(value)}")
        return [int(v) if integer else float(v) for v in value]

    def texts(self, key, n=None, default=_MISSING):
        """A list of ``n`` names (text)."""
        value = self._value(key, default)
        if not isinstance(value, list) or (n is not None and len(value) != n) or not all(isinstance(v, str)
                                                                                        for v in value):
            self.fail(key, f"must be a list of {'' if n is None else f'{n} '}names (text), got {shown(value)}")
        return list(value)

    def choice(self, key, options, default=_MISSING):
        """One of the words ``options``."""
        value = self._value(key, default)
        if not isinstance(value, str) or value not in options:
            self.fail(key, f"must be one of {list(options)}, got {shown(value)}")
        return value


def _fits(v, low, integer):
    x = real(v)
    if x is None or not math.isfinite(x) or (integer and not isinstance(v, int)):
        return False
    return low is None or x >= low
