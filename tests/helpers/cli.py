"""Running ``mutual`` on the examples and checking its one-line errors, shared by the command line's tests."""

import io
import os
import subprocess
import sys
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

from mutual.cli import main


ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "data" / "examples"
MALFORMED = EXAMPLES / "malformed"
SCRIPT = Path(sys.executable).with_name("mutual")


def console(*args, cwd):
    """Run the installed console script (or ``python -m mutual.cli`` where it is not installed) as its own process."""
    command = [str(SCRIPT)] if SCRIPT.exists() else [sys.executable, "-m", "mutual.cli"]
    return subprocess.run(command + [str(a) for a in args], cwd=cwd, capture_output=True, text=True, timeout=900)


def mutual(*args, cwd):
    """``mutual ARGS`` run in ``cwd`` in this process, as the console script runs it (``mutual.cli.main``; an
    argparse usage error's exit too): a ``CompletedProcess`` with its exit status, stdout and stderr. The
    libraries are imported once for every test, not once per command."""
    out, err, here = io.StringIO(), io.StringIO(), os.getcwd()
    os.chdir(cwd)
    try:
        with redirect_stdout(out), redirect_stderr(err):
            try:
                status = main([str(a) for a in args])
            except SystemExit as stop:
                status = stop.code
    finally:
        os.chdir(here)
    return subprocess.CompletedProcess(["mutual", *map(str, args)], status, out.getvalue(), err.getvalue())


def assert_one_line_error(run, *phrases):
    assert run.returncode == 2, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mutual ") and ": error: " in lines[0], run.stderr
    assert "Traceback" not in run.stderr
    for phrase in phrases:
        assert phrase in lines[0], lines[0]


def no_temporaries(folder):
    return not [p for p in Path(folder).iterdir() if p.name.startswith(".")]


def refuses_in_one_line(argv, files, phrases, folder):
    """``mutual ARGV --no-progress`` in ``folder`` on ``files`` ({name: text, bytes, or {} for a folder}):
    exit status 2, one line naming every phrase, and nothing written (a bad-input table's check)."""
    folder = Path(folder)
    for name, content in files.items():
        if isinstance(content, dict):
            (folder / name).mkdir()
        elif isinstance(content, bytes):
            (folder / name).write_bytes(content)
        else:
            (folder / name).write_text(content)
    before = set(folder.iterdir())
    assert_one_line_error(mutual(*argv, "--no-progress", cwd=folder), *phrases)
    assert set(folder.iterdir()) == before, "nothing is written on bad input"
