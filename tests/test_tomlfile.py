"""TOML inputs as users write them (``mutual.tomlfile``): a byte-order mark reads as without, other encodings
are named."""

import codecs

import pytest

from mutual.constraints.world import load_world
from mutual.tomlfile import read_toml


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
