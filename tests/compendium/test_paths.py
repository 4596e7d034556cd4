"""The repository's paths are anchored at its root, whatever the working directory."""

import subprocess
import sys

import mutual.compendium.paths as paths


def test_root_is_independent_of_working_directory(tmp_path):
    out = subprocess.run([sys.executable, "-c", "import mutual.compendium.paths as p; print(p.ROOT)"],
                         cwd=tmp_path, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == str(paths.ROOT)
    assert (paths.ROOT / "pyproject.toml").exists()
