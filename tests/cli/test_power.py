"""``mutual study power`` and ``python -m mutual.cli.power``: analytic and simulated plans as JSON, sample-size
arguments, options refused by name (exit 2, one line) before any work, zero effect printed as not reached,
help that states measured times, and a command that builds without the numerical stack."""

import json
import subprocess
import sys
import tracemalloc

import pandas as pd
import pytest

from mutual.cli import main
from mutual.study import cohort_power as cp, power_summary as ps


def test_command_line_analytic_json(capsys, tmp_path):
    from mutual.cli import power as cli
    from mutual.study import power as pw
    assert cli.main(["--analytic-only", "--json", "--out", str(tmp_path)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["analytic"]["eta2p_bias_corrected"] == pytest.approx(pw.effect_size_from_f(8.72, 2, 20).eta2p_unbiased)
    plan = pd.read_csv(tmp_path / "power_plan.csv")
    assert plan["N for 80%"].tolist() == pw.replication_plan(8.72, 2, 20)["N for 80%"].tolist()
    assert cli.main(["--analytic-only", "--from-f", "8.72", "2", "21", "--out", str(tmp_path)]) == 2
    assert "is not a one-way repeated-measures design" in capsys.readouterr().err


def test_command_line_simulation_json(capsys, tmp_path, monkeypatch):
    from mutual.cli import power as cli
    monkeypatch.setenv("MUTUAL_CACHE_DIR", str(tmp_path))
    args = ["--quick", "--inline", "--n", "3:4", "--cohorts", "2", "--json", "--no-progress", "--out", str(tmp_path)]
    assert cli.main(args) == 0
    doc = json.loads(capsys.readouterr().out)["simulated"]
    assert doc["SIMULATED"] and doc["n"] == [3, 4] and doc["sweep"]["computed"] == 2
    assert {r["test"] for r in doc["power"]} >= set(ps.KEY_TESTS)
    assert {p.name for p in tmp_path.glob("power_*")} == {"power_plan.csv", "power_simulated.csv",
                                                          "power_recommended.csv", "power_curves.png"}
    assert cli.main(args) == 0
    assert json.loads(capsys.readouterr().out)["simulated"]["sweep"]["cached"] == 2
    assert cli.main(["--quick", "--inline", "--n", "x", "--out", str(tmp_path)]) == 2
    assert "--n: 'x' is not a whole number" in capsys.readouterr().err


def test_mutual_study_power_through_the_command_line(capsys, tmp_path, monkeypatch):
    """The one-line wiring of the cli's study group: EXTENSIONS = ("power",)."""
    from mutual import cli
    from mutual.cli import study
    monkeypatch.setattr(study, "EXTENSIONS", ("power",))
    assert cli.main(["study", "power", "--analytic-only", "--json", "--out", str(tmp_path)]) == 0
    assert json.loads(capsys.readouterr().out)["command"] == "study power"


def test_the_command_builds_without_the_numerical_stack():
    """Wired into `mutual`, `mutual --help` still imports neither numpy nor jax (tests/cli/test_cli.py's rule)."""
    from mutual.cli import power as cli
    assert set(cli.MIX_NAMES) == set(cp.MIXES)
    code = ("import sys, mutual.cli.study as s; s.EXTENSIONS = ('power',); import mutual.cli as c; c.build_parser(); "
            "print(sorted(m for m in ('jax', 'numpy', 'pandas', 'scipy', 'matplotlib') if m in sys.modules))")
    probe = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert probe.stdout.strip() == "[]", probe.stdout + probe.stderr


@pytest.mark.parametrize("tokens, expected", [(["6:10:2", "11"], [6, 8, 10, 11]), (["5,7"], [5, 7]), (["4:6"], [4, 5, 6])])
def test_sample_size_arguments(tokens, expected):
    from mutual.cli.power import parse_sizes
    assert parse_sizes(tokens) == expected


@pytest.mark.parametrize("tokens", [["x"], ["6:4"], ["6:10:0"], ["2"]])
def test_bad_sample_size_arguments(tokens):
    from mutual.cli.power import parse_sizes
    with pytest.raises(ValueError, match="--n"):
        parse_sizes(tokens)


def test_a_huge_range_of_sizes_is_refused_before_it_is_listed():
    from mutual import budget
    from mutual.cli.power import parse_sizes
    tracemalloc.start()
    with budget.limits(minutes=30), pytest.raises(ValueError, match=r"99,999,998 sample sizes \(--n 3:100000000\): about .* GiB .*--n a:b:step"):
        parse_sizes(["3:100000000"])
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 1_000_000


CLI_REFUSED = [  # (argv after `mutual study power`, phrases); exit status 2 with one line naming the option
    (["--n", "3:100000000"], ["60 simulated cohorts of 100,000,000 participants", "GiB", "years", "--allow-large"]),
    (["--f", "0.25", "--n", "1:100000000"], ["100,000,000 sample sizes (--n 1:100000000)", "hours", "--allow-large"]),
    (["--f", "0.25", "--n", "3:10000000"], ["9,999,998 sample sizes", "GiB", "hours", "--allow-large"]),
    (["--n", "1001", "--quick", "--inline"], ["60 simulated cohorts of 1,001 participants", "hours", "--n", "--allow-large"]),
    (["--quick", "--n", "100000", "--cohorts", "1", "--inline"],
     ["1 simulated cohorts of 100,000 participants", "8.89 hours", "the limit is 30 minutes", "--allow-large"]),
    (["--quick", "--n", "6", "--cohorts", "1000000000", "--inline"],
     ["1,000,000,000 simulated cohorts of 6 participants", "GiB of memory", "61 years", "--cohorts", "--allow-large"]),
    (["--cohorts", "1000000"], ["--cohorts", "days", "GiB", "--allow-large"]),
    (["--seed", "-1"], ["--seed", ">= 0"]),
    (["--seed", "nan"], ["--seed", "not a whole number"]),
    (["--seed", "1.5"], ["--seed", "not a whole number"]),
    (["--cohorts", "0"], ["--cohorts"]),
    (["--workers", "0"], ["--workers"]),
    (["--noise", "nan"], ["--noise", "finite"]),
    (["--alpha", "1.5"], ["--alpha"]),
    (["--f", "0.25", "--rho", "-0.6"], ["--rho -0.6", "-1/(m-1)"]),
    (["--f", "0.25", "--rho", "1"], ["--rho"]),
    (["--f", "0.25", "--eps", "0.4"], ["--eps 0.4", "[0.5, 1]"]),
    (["--f", "0.25", "--power", "0.04"], ["--power 0.04", "--alpha"]),
    (["--f", "1e300"], ["f must be at most"]),
    (["--f", "0.25", "--cohorts", "5"], ["--cohorts", "simulation option"]),
    (["--f", "0.25", "--from-f", "8", "2", "20"], ["--f and --from-f"]),
    (["--analytic-only", "--from-f", "8", "1e300", "20"], ["--from-f", "levels"]),
    (["--analytic-only", "--from-f", "1e300", "2", "20"], ["1e+300", "nothing to plan"]),
    (["--analytic-only", "--from-f", "8", "2.5", "20"], ["--from-f", "whole numbers"]),
    (["--analytic-only", "--rho", "0.2"], ["--rho goes with --f"]),
    (["--analytic-only", "--m", "4"], ["--m 4", "3 levels"]),
]


@pytest.mark.parametrize("argv, phrases", CLI_REFUSED, ids=[" ".join(c[0]) for c in CLI_REFUSED])
def test_power_options_are_refused_by_name(argv, phrases, tmp_path, capsys):
    try:
        status = main(["study", "power", *argv, "--out", str(tmp_path / "o"), "--no-progress"])
    except SystemExit as stop:            # argparse's own refusal (usage, then one error line)
        status = stop.code
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert status == 2 and "Traceback" not in err and all(p in err for p in phrases), err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("f, n", [(0.25, 1_000_000), (1e-4, 10 ** 8), (0.01, 123_457)])
def test_the_analytic_power_at_any_n_is_computed_not_refused(tmp_path, capsys, f, n):
    """G*Power's power at N costs the same at any N: as scipy's noncentral F (lambda = f^2 N m / (1 - rho))."""
    from scipy import stats
    out = tmp_path / "o"
    assert main(["study", "power", "--f", str(f), "--n", str(n), "--out", str(out), "--no-progress"]) == 0
    row = pd.read_csv(out / "power_gpower.csv").iloc[0]
    lam, df1, df2 = f * f * n * 3 / 0.5, 2, 2 * (n - 1)
    assert row["n"] == n and row["lambda"] == pytest.approx(lam, rel=1e-12)
    assert row["power"] == pytest.approx(stats.ncf.sf(stats.f.isf(0.05, df1, df2), df1, df2, lam), rel=1e-9, abs=1e-12)


def test_zero_effect_prints_not_reached(tmp_path, capsys):
    assert main(["study", "power", "--analytic-only", "--from-f", "0.5", "2", "20", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    sizes = [line.split()[-2:] for line in out.splitlines() if line.rstrip().endswith(("reached", "0", "6"))]
    assert ["not", "reached"] in sizes and ["66", "86"] in sizes
    assert "nan" not in out.lower() and "66.000" not in out
    assert main(["study", "power", "--f", "0", "--json", "--out", str(tmp_path)]) == 0
    rows = json.loads(capsys.readouterr().out)["gpower"]["rows"]
    assert [r["n"] for r in rows] == [None, None]


def test_the_help_states_measured_times_and_has_no_stray_markup(capsys):
    for argv in (["study", "anova", "--help"], ["study", "power", "--help"]):
        with pytest.raises(SystemExit):
            main(argv)
        text = capsys.readouterr().out
        assert "Measured" in text and "::" not in text and "well under a second" not in text
