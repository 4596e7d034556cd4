"""Where expensive results are cached: ``$MUTUAL_CACHE_DIR``, else the user's cache folder
(``$XDG_CACHE_HOME/mutual``, by default ``~/.cache/mutual``). The compendium's Makefile points
it at the repository's ``.cache/`` so that ``make clean`` removes it."""

import os
from pathlib import Path


def cache_dir() -> Path:
    """The cache folder (not created here; writers create what they need)."""
    if os.environ.get("MUTUAL_CACHE_DIR"):
        return Path(os.environ["MUTUAL_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "mutual"
