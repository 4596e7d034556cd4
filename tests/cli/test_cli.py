"""The ``mutual`` command line as a whole: the console script is installed and its help is fast and light,
every level has help, a group without a command is a usage error, an unexpected failure is one line with
status 1, ``--json`` prints one object (NaN as null), and the README's Python snippets run on the examples."""

import json
import subprocess
import sys

import pytest

from mutual.cli import main

from helpers.cli import EXAMPLES, ROOT, SCRIPT, console


def test_the_console_script_is_installed_and_help_is_fast_and_light():
    assert SCRIPT.exists(), "make env installs the package with its console script"
    run = console("--help", cwd=ROOT)
    assert run.returncode == 0
    for group in ("constraints", "supervisor", "study", "motion"):
        assert group in run.stdout
    # --help imports neither jax nor the numerical stack: the command modules import them lazily
    probe = subprocess.run([sys.executable, "-c", "import sys, mutual.cli as c; c.build_parser(); "
                            "print(sorted(m for m in ('jax', 'numpy', 'pandas', 'scipy', 'matplotlib') "
                            "if m in sys.modules))"], capture_output=True, text=True, timeout=120)
    assert probe.stdout.strip() == "[]", probe.stdout + probe.stderr


@pytest.mark.parametrize("argv, phrase", [
    (["constraints", "--help"], "infer"),
    (["constraints", "infer", "--help"], "--min-gain"),
    (["supervisor", "--help"], "fit"),
    (["supervisor", "fit", "--help"], "the first time"),
    (["study", "--help"], "anova"),
    (["study", "anova", "--help"], "Greenhouse-Geisser"),
    (["motion", "--help"], "legible"),
    (["motion", "legible", "--help"], "SPEC.toml"),
])
def test_help_on_every_level(argv, phrase, capsys):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 0
    assert phrase in capsys.readouterr().out


def test_a_group_without_a_command_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["study"])
    assert stop.value.code == 2
    assert "required" in capsys.readouterr().err


def test_the_readme_python_snippets_run_on_the_examples(tmp_path):
    """Each task's three lines of Python in the README run as written on the example inputs."""
    text = (ROOT / "README.md").read_text()
    section = text.split("## Your own data", 1)[1].split("\n## ", 1)[0]
    blocks = [b.split("```", 1)[0] for b in section.split("```python\n")[1:]]
    assert len(blocks) == 4 and all(len(b.strip().splitlines()) == 3 for b in blocks)
    for name in ("world.toml", "demonstrations.csv", "interventions.csv", "study.csv", "legible.toml"):
        (tmp_path / name).write_bytes((EXAMPLES / name).read_bytes())
    script = "\n".join(blocks) + "\nprint('ALL RAN')\n"
    run = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0 and "ALL RAN" in run.stdout, run.stderr[-2000:]


SPEC = 'start = [0, 0]\ngoal = [1, 1]\ndistractors = [[-1, 1]]\nhorizon = 1.0\nsteps = 10\nalpha = 1.0\n'


def test_an_unexpected_failure_is_one_line_with_status_1(tmp_path, monkeypatch, capsys):
    from mutual.cli import motion
    monkeypatch.chdir(tmp_path)
    (tmp_path / "spec.toml").write_text(SPEC)

    def broken(spec):
        raise RuntimeError("solver exploded\nsecond line")
    monkeypatch.setattr("mutual.motion.spec.solve_legible", broken)
    monkeypatch.delenv("MUTUAL_DEBUG", raising=False)
    assert motion.run_legible.__module__ == "mutual.cli.motion"
    assert main(["motion", "legible", "spec.toml", "--no-progress"]) == 1
    err = capsys.readouterr().err.strip()
    assert err == ("mutual motion legible: error: RuntimeError: solver exploded second line "
                   "(set MUTUAL_DEBUG=1 for the traceback)")
    monkeypatch.setenv("MUTUAL_DEBUG", "1")
    with pytest.raises(RuntimeError):
        main(["motion", "legible", "spec.toml", "--no-progress"])


def test_json_output_is_one_object_with_nan_as_null(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "spec.toml").write_text(SPEC)
    assert main(["motion", "legible", "spec.toml", "--json", "--no-progress"]) == 0
    out = capsys.readouterr().out
    r = json.loads(out)
    assert r["command"] == "motion legible" and r["eta"] is None and r["duals"] is None
    assert sorted(p.name for p in tmp_path.iterdir()) == ["legible_trajectory.csv", "legible_trajectory.png",
                                                         "spec.toml"]
