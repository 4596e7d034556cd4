"""The one TOML reader (mutual.inputs.read_toml) and its key checks (Keys): nesting that would exhaust
Python's stack is refused naming the file, what tomllib reads is returned unchanged (tomllib is the truth),
and every key error names the file and the key."""

import codecs
import tomllib

import pytest

from mutual.constraints.continuous import load_system
from mutual.constraints.world import load_world
from mutual.inputs import MAX_DEPTH, Keys, read_toml
from mutual.motion.spec import load_legible_spec

DEEP = [  # (case, TOML text)
    ("100 000 brackets", "a = " + "[" * 100_000 + "]" * 100_000 + "\n"),
    ("100 000 inline tables", "a = " + "{b = " * 100_000 + "1" + "}" * 100_000 + "\n"),
    ("one more than the limit", "a = " + "[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1) + "\n"),
    ("brackets never closed", "a = " + "[" * 5000 + "\n"),
]


@pytest.mark.parametrize("case, text", DEEP, ids=[c[0] for c in DEEP])
@pytest.mark.parametrize("loader", [read_toml, load_world, load_legible_spec, load_system],
                         ids=["read_toml", "world", "spec", "system"])
def test_nesting_beyond_the_limit_is_refused_naming_the_file(case, text, loader, tmp_path):
    path = tmp_path / "deep.toml"
    path.write_text(text)
    with pytest.raises(ValueError, match=f"^{path}: not valid TOML for mutual \\(arrays or tables nested more than "
                                         f"{MAX_DEPTH} deep"):
        loader(path)


@pytest.mark.parametrize("text", [
    "a = " + "[" * MAX_DEPTH + "]" * MAX_DEPTH + "\n",
    'a = "' + "[" * 100_000 + '"\n',                         # brackets inside a string are text
    "a = '''" + "{[" * 50_000 + "'''\n# " + "[" * 1000 + "\n",  # ... and in a literal string and a comment
    "[t]\nx = [[1, 2], [3, 4]]\n[[u]]\ny = {z = [1]}\n",
])
def test_what_tomllib_reads_is_returned_unchanged(text, tmp_path):
    path = tmp_path / "ok.toml"
    path.write_text(text)
    assert read_toml(path) == tomllib.loads(text)


KEYS = [  # (the call on Keys({"a": ..., "t": {...}}, "f.toml"), the message)
    (lambda k: k.known(("a", "s", "t")), "f.toml: key 'l': unknown key (known: a, s, t)"),
    (lambda k: k.known(("a", "s", "l", "t", "b"), ("b",)), "f.toml: key 'b': missing (required)"),
    (lambda k: k.number("a", 0, 1), "f.toml: key 'a': must be a number in [0, 1], got 2"),
    (lambda k: k.number("s"), "f.toml: key 's': must be a finite number, got 'x'"),
    (lambda k: k.table("t", ("y",)), "f.toml: key 't.z': unknown key (known: y)"),
    (lambda k: k.table("t").number("z", integer=True), "f.toml: key 't.z': must be an integer, got 1.5"),
    (lambda k: k.table("a"), "f.toml: key 'a': must be a table [a]"),
    (lambda k: k.numbers("l", 3), "f.toml: key 'l': must be a list of 3 numbers, got [1, 'b']"),
    (lambda k: k.numbers("l", sizes=(2, 3), low=0), "f.toml: key 'l': must be a list of 2 or 3 numbers >= 0"),
    (lambda k: k.texts("l", 2), "f.toml: key 'l': must be a list of 2 names (text), got [1, 'b']"),
    (lambda k: k.choice("s", ("y", "z")), "f.toml: key 's': must be one of ['y', 'z'], got 'x'"),
]


@pytest.mark.parametrize("call, message", KEYS, ids=[m[8:40] for _, m in KEYS])
def test_key_errors_name_the_file_and_the_key(call, message):
    keys = Keys({"a": 2, "s": "x", "l": [1, "b"], "t": {"z": 1.5}}, "f.toml")
    with pytest.raises(ValueError) as err:
        call(keys)
    assert str(err.value).startswith(message), err.value


def test_a_value_that_is_not_a_table_is_named():
    with pytest.raises(ValueError, match="f.toml: must be a table of keys, got list"):
        Keys([1, 2], "f.toml")


WORLD = "width = 5\nheight = 4\nstart = [0, 0]\ngoal = [4, 0]\nslip = 0.1\n"


@pytest.mark.parametrize("encoding, text", [
    ("a UTF-8 byte-order mark", codecs.BOM_UTF8 + WORLD.encode()),
    ("a byte-order mark and CRLF line ends", codecs.BOM_UTF8 + WORLD.replace("\n", "\r\n").encode()),
    ("plain UTF-8", WORLD.encode()),
])
def test_a_world_file_with_a_byte_order_mark_reads_as_without(tmp_path, encoding, text):
    path = tmp_path / "world.toml"
    path.write_bytes(text)
    assert read_toml(path) == read_toml_text(WORLD)
    grid = load_world(path)
    assert (grid.width, grid.height, grid.goal) == (5, 4, (4, 0))


def read_toml_text(text):
    import tomllib
    return tomllib.loads(text)


@pytest.mark.parametrize("what, data, message", [
    ("UTF-16 text", WORLD.encode("utf-16"), r"not valid TOML \(not UTF-8 text"),
    ("a byte-order mark only", codecs.BOM_UTF8, r"key 'width': missing"),
    ("a byte-order mark twice", codecs.BOM_UTF8 * 2 + WORLD.encode(), r"not valid TOML"),
])
def test_other_encodings_are_named(tmp_path, what, data, message):
    path = tmp_path / "world.toml"
    path.write_bytes(data)
    with pytest.raises(ValueError, match=f"{path}: .*{message}"):
        load_world(path)
