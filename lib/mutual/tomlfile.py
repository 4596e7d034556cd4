"""Reading the TOML input files of the command line (worlds, legibility specs)."""

import codecs
import tomllib
from pathlib import Path


def read_toml(path):
    """The mapping in the TOML file ``path``; a ValueError naming the file when it is not valid TOML.

    A UTF-8 byte-order mark (as some Windows editors write) is accepted, as the CSV readers accept it.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
        text = data.removeprefix(codecs.BOM_UTF8).decode("utf-8")
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"{path}: not valid TOML ({err})") from None
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not valid TOML (not UTF-8 text: byte {err.start})") from None
