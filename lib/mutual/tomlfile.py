"""Reading the TOML input files of the command line (worlds, legibility specs)."""

import tomllib
from pathlib import Path


def read_toml(path):
    """The mapping in the TOML file ``path``; a ValueError naming the file when it is not valid TOML."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"{path}: not valid TOML ({err})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not valid TOML (not UTF-8 text)") from None
