"""Running the ``mutual`` console script on the examples and checking its one-line errors, shared by the
command line's tests."""

import subprocess
import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "data" / "examples"
MALFORMED = EXAMPLES / "malformed"
SCRIPT = Path(sys.executable).with_name("mutual")


def mutual(*args, cwd):
    """Run the installed console script (or ``python -m mutual.cli`` where it is not installed)."""
    command = [str(SCRIPT)] if SCRIPT.exists() else [sys.executable, "-m", "mutual.cli"]
    return subprocess.run(command + [str(a) for a in args], cwd=cwd, capture_output=True, text=True, timeout=900)


def assert_one_line_error(run, *phrases):
    assert run.returncode == 2, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mutual ") and ": error: " in lines[0], run.stderr
    assert "Traceback" not in run.stderr
    for phrase in phrases:
        assert phrase in lines[0], lines[0]


def no_temporaries(folder):
    return not [p for p in Path(folder).iterdir() if p.name.startswith(".")]
