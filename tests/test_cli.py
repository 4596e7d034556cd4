"""The ``mutual`` command line end to end (issue 11, part 3): every command through the real console
script on its example in data/examples/, on a malformed file (exit 2, one line naming the file and
the column or key, no traceback) and on a fresh input written by the test, whose answer is checked
against independent truth; ``--json`` parses; outputs land atomically in ``--out``."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from mutual.cli import main


ROOT = Path(__file__).resolve().parents[1]
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


# ---- the console script and --help ------------------------------------------------------------

def test_the_console_script_is_installed_and_help_is_fast_and_light():
    assert SCRIPT.exists(), "make env installs the package with its console script"
    run = mutual("--help", cwd=ROOT)
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


# ---- mutual study anova ---------------------------------------------------------------------------

def _fresh_study(path, rng):
    """A repeated-measures table with made-up level names, one row per subject and level."""
    levels = ["zeta", "alpha", "mid point"]
    rows = [{"who": f"s{i}", "cond": c, "y": 10 + 2 * j + rng.normal()} for i in range(9) for j, c in enumerate(levels)]
    pd.DataFrame(rows).to_csv(path, index=False)
    return pd.DataFrame(rows)


def test_study_anova_on_a_fresh_csv_matches_the_textbook_formulas(tmp_path):
    data = _fresh_study(tmp_path / "fresh.csv", np.random.default_rng(3))
    run = mutual("study", "anova", "fresh.csv", "--dv", "y", "--within", "cond", "--subject", "who", "--json",
                 "--out", "out", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    r = json.loads(run.stdout)
    for key in ("F", "df1", "df2", "p", "eps", "p_gg", "pairwise"):
        assert key in r
    # independent truth: the one-way repeated-measures decomposition by hand
    y = data.pivot(index="who", columns="cond", values="y").to_numpy()
    n, k = y.shape
    ss_cond = n * ((y.mean(axis=0) - y.mean()) ** 2).sum()
    ss_err = ((y - y.mean(axis=1, keepdims=True) - y.mean(axis=0, keepdims=True) + y.mean()) ** 2).sum()
    F = (ss_cond / (k - 1)) / (ss_err / ((k - 1) * (n - 1)))
    assert r["F"] == pytest.approx(F, rel=1e-9)
    assert (r["df1"], r["df2"]) == (k - 1, (k - 1) * (n - 1))
    assert r["p"] == pytest.approx(stats.f.sf(F, k - 1, (k - 1) * (n - 1)), rel=1e-6)
    assert 1 / (k - 1) - 1e-12 <= r["eps"] <= 1 + 1e-12 and r["p_gg"] >= r["p"] - 1e-15
    assert sorted(r["levels"]) == ["alpha", "mid point", "zeta"]
    # the paired t-tests and Holm's correction, by hand
    wide = data.pivot(index="who", columns="cond", values="y")
    raw = {(p["A"], p["B"]): stats.ttest_rel(wide[p["A"]], wide[p["B"]]).pvalue for p in r["pairwise"]}
    order = sorted(raw.values())
    holm = {pair: min(1.0, max((len(order) - i) * order[i] for i in range(order.index(p) + 1)))
            for pair, p in raw.items()}
    for p in r["pairwise"]:
        assert p["p_holm"] == pytest.approx(holm[(p["A"], p["B"])], rel=1e-9)
    assert sorted(Path(tmp_path, "out").iterdir())
    assert no_temporaries(tmp_path / "out")


def test_study_anova_on_the_example(tmp_path):
    run = mutual("study", "anova", EXAMPLES / "study.csv", "--dv", "value", "--within", "treatment", "--subject",
                 "participant", "--where", "measure=false_positives", "--aggregate", "mean", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "Greenhouse-Geisser" in run.stdout and "Tukey" in run.stdout
    written = {p.name for p in tmp_path.iterdir()}
    assert {"anova_value_false_positives.csv", "pairwise_value_false_positives.csv",
            "means_value_false_positives.png"} <= written


def test_study_anova_on_a_malformed_file_names_the_file_line_and_column(tmp_path):
    run = mutual("study", "anova", MALFORMED / "study_bad_value.csv", "--dv", "value", "--within", "treatment",
                 "--subject", "participant", cwd=tmp_path)
    assert_one_line_error(run, "study_bad_value.csv", "column 'value'", "line 7")
    assert not list(tmp_path.iterdir())


# ---- mutual motion legible ------------------------------------------------------------------------

def test_motion_legible_on_a_fresh_spec_matches_the_closed_form(tmp_path):
    # goals (-1, 1) and (1, 1), dt = 0.01, N = 100, alpha = 1: the legible optimum applies the constant
    # control u = (1.5, 0.5) and ends at (1.5, 0.5); the predictable optimum ends at (0.5, 0.5)
    (tmp_path / "spec.toml").write_text('start = [0, 0]\ngoal = [1, 1]\ndistractors = [[-1, 1]]\n'
                                        'horizon = 1.0\nsteps = 100\nalpha = 1.0\n')
    run = mutual("motion", "legible", "spec.toml", "--json", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    r = json.loads(run.stdout)
    assert r["final_position"] == pytest.approx([1.5, 0.5], abs=1e-9)
    assert r["predictable_final_position"] == pytest.approx([0.5, 0.5], abs=1e-9)
    assert r["evidence"]["legible"][0] < r["evidence"]["predictable"][0] < 0
    table = pd.read_csv(tmp_path / "legible_trajectory.csv")
    assert len(table) == 101 and np.allclose(table[["u_x", "u_y"]].iloc[:-1], [1.5, 0.5], atol=1e-9)
    assert table[["u_x", "u_y"]].iloc[-1].isna().all()


def test_motion_legible_on_the_example(tmp_path):
    run = mutual("motion", "legible", EXAMPLES / "legible.toml", "--out", tmp_path / "o", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "log Lambda" in run.stdout
    assert {p.name for p in (tmp_path / "o").iterdir()} == {"legible_trajectory.csv", "legible_trajectory.png"}


def test_motion_legible_on_a_malformed_spec(tmp_path):
    assert_one_line_error(mutual("motion", "legible", MALFORMED / "legible_bad_alpha.toml", cwd=tmp_path),
                          "legible_bad_alpha.toml", "key 'alpha'", "positive")


# ---- mutual supervisor fit ------------------------------------------------------------------------

def test_supervisor_fit_recovers_a_fresh_simulated_supervisor(tmp_path):
    from mutual.supervision import NoisySupervisor, value_library, write_interventions
    from mutual.supervision import QUICK_GRID
    from mutual.supervision.supervisor import approach_scenes
    from mutual.supervision.exact import exact_counterpart
    library = value_library([0.5, 1.0, 2.0], 1.0, QUICK_GRID, progress=False)
    rng = np.random.default_rng(5)
    # the supervisor judges on its exact safe set, as the fit evaluates it; one simulated on the quick grid's
    # interpolated values would carry the grid's error (about 0.09 in mu here) into its interventions
    sup = NoisySupervisor(exact_counterpart(library[library.index_of(0.5)]), 0.4, 0.03)
    states, scene = sup.first_interventions(approach_scenes(60, rng, 1.0, 7.5), rng)
    frame = pd.DataFrame({"participant": "p-new", "trial": scene, "time": 1.0, "x": states[:, 0],
                          "y": states[:, 1], "theta": states[:, 2]})
    write_interventions(frame, tmp_path / "fresh.csv")
    run = mutual("supervisor", "fit", "fresh.csv", "--grid", "quick", "--w-max", "0.5,1,2", "--level", "2",
                 "--json", "--no-progress", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    fit = json.loads(run.stdout)["fits"][0]
    assert fit["participant"] == "p-new" and fit["n"] == len(states)
    assert fit["w_max"] == 0.5
    assert fit["mu"] == pytest.approx(0.4, abs=0.03) and fit["sigma"] == pytest.approx(0.03, abs=0.02)
    assert fit["alpha"] == pytest.approx(fit["mu"] + 2 * fit["sigma"], rel=1e-12)


def test_supervisor_fit_on_the_example(tmp_path):
    run = mutual("supervisor", "fit", EXAMPLES / "interventions.csv", "--grid", "quick", "--prior", "map",
                 "--no-progress", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    for who in ("sim-01", "sim-02", "sim-03"):
        assert who in run.stdout
    table = pd.read_csv(tmp_path / "supervisor_fit.csv")
    assert list(table["participant"]) == ["sim-01", "sim-02", "sim-03"]
    assert (table["mu"] >= 0).all()          # MAP: mu* = max(mu*, 0)


def test_supervisor_fit_closed_form_recovers_the_example_supervisors(tmp_path):
    """The example's three simulated supervisors (generated on the HJ full grid) have w_max 1, 0.75, 0.5
    and mu 0.3, 0.2, 0.5; the exact closed-form library finds them in about a second."""
    run = mutual("supervisor", "fit", EXAMPLES / "interventions.csv", "--method", "closed-form", "--json",
                 "--no-progress", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    fits = {f["participant"]: f for f in json.loads(run.stdout)["fits"]}
    assert [fits[p]["w_max"] for p in ("sim-01", "sim-02", "sim-03")] == [1.0, 0.75, 0.5]
    for p, mu in (("sim-01", 0.3), ("sim-02", 0.2), ("sim-03", 0.5)):
        assert fits[p]["mu"] == pytest.approx(mu, abs=0.05)


def test_supervisor_fit_on_a_malformed_file(tmp_path):
    run = mutual("supervisor", "fit", MALFORMED / "interventions_bad_theta.csv", "--grid", "quick", cwd=tmp_path)
    assert_one_line_error(run, "interventions_bad_theta.csv", "line 5, column 'theta'", "'left'")


# ---- mutual constraints infer ---------------------------------------------------------------------

WORLD = """width = 5\nheight = 4\nstart = [0, 0]\ngoal = [4, 0]\nslip = 0.05\nhorizon = 10\nloiter = "goal"\n"""


def test_constraints_infer_finds_a_fresh_ground_truth_constraint(tmp_path):
    from mutual.constraints import constraint_mask, sample_demonstrations, write_demonstrations
    from mutual.constraints.world import world_from_mapping
    import tomllib
    (tmp_path / "world.toml").write_text(WORLD)
    grid = world_from_mapping(tomllib.loads(WORLD))
    blocked = grid.state(2, 0)                # the middle of the straight path from start to goal
    truth = constraint_mask(grid.mdp, [blocked], 0.25)      # no move aimed at it; slips may land there
    write_demonstrations(tmp_path / "demos.csv", sample_demonstrations(grid.mdp, 80, truth, rng=4))
    run = mutual("constraints", "infer", "demos.csv", "--world", "world.toml", "--rounds", "3", "--json",
                 "--no-progress", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    r = json.loads(run.stdout)
    first = r["chosen"][0]
    assert (first["kind"], first["col"], first["row"]) == ("state", 2, 0)
    assert first["F"] < np.exp(-0.1) and first["neg_log_F"] == pytest.approx(-np.log(first["F"]), rel=1e-9)
    ranking = pd.read_csv(tmp_path / "constraints_ranking.csv")
    round1 = ranking[ranking["round"] == 1]
    assert round1["F"].is_monotonic_increasing and round1["chosen"].sum() == 1
    assert no_temporaries(tmp_path)


def test_constraints_infer_on_the_example(tmp_path):
    run = mutual("constraints", "infer", EXAMPLES / "demonstrations.csv", "--world", EXAMPLES / "world.toml",
                 "--no-progress", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "round 1" in run.stdout and "Stopped:" in run.stdout
    assert {"constraints_ranking.csv", "constraints_chosen.csv", "constraints.png"} <= {p.name for p in
                                                                                        tmp_path.iterdir()}


@pytest.mark.parametrize("demos, world, phrases", [
    ("demonstrations_bad_action.csv", EXAMPLES / "world.toml",
     ["demonstrations_bad_action.csv", "column 'action'", "line 3", "'north'"]),
    (EXAMPLES / "demonstrations.csv", "world_bad_slip.toml", ["world_bad_slip.toml", "key 'slip'", "[0, 1]"]),
])
def test_constraints_infer_on_malformed_files(demos, world, phrases, tmp_path):
    run = mutual("constraints", "infer", MALFORMED / demos, "--world", MALFORMED / world, cwd=tmp_path)
    assert_one_line_error(run, *phrases)


# ---- the README's "Your own data" section ----------------------------------------------------------

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
