"""The pip-compile locks (environment.lock, installer.lock, bench/peers/requirements.lock) read as data."""

import re

from packaging.utils import canonicalize_name as canonical

REQUIREMENT = re.compile(r"^([A-Za-z0-9_.\-]+)==([^\s;]+)(?:\s*;[^-]*)?\s+(--hash=sha256:[0-9a-f]{64}\s*)+$")


def options(path):
    """The lock's option lines (``--find-links ...``, ``--index-url ...``; not a requirement's ``--hash``)."""
    return [line for line in path.read_text().splitlines() if line.startswith("--")]


def pins(path):
    """``{canonical name: version}`` of a lock; every requirement pinned with ``==`` and hashed."""
    text = path.read_text().replace("\\\n", " ")
    found = {}
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        match = REQUIREMENT.match(line)
        assert match, f"{path.name}: not a pinned, hashed requirement: {line[:80]}"
        found[canonical(match.group(1))] = match.group(2)
    return found
