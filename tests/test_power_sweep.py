"""The SIMULATED cohort sweep on Dask (issue 16): identical results inline, on an embedded
LocalCluster of 2 workers and on a scheduler with a worker started as separate processes and
reached by address; a cache that resumes an interrupted sweep; the command line."""

import json
import os
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

from mutual.cache import CacheWarning
from mutual.study import cohort
from mutual.study import cohort_power as cp
from mutual.study import power_summary as ps
from mutual.study import power_plots, sweep

TINY = cp.CohortSetting(n_scenes=10, trial_seconds=3.0, quick_grid=True)


@pytest.fixture(scope="module")
def library():
    return cohort.study_value_functions(quick=True)


@pytest.fixture(scope="module")
def tasks():
    return [cp.CohortTask(TINY, c, 5) for c in range(4)]


@pytest.fixture(scope="module")
def inline(library, tasks):
    results, stats = sweep.run_tasks(cp.simulate_cohort, tasks, shared=library, scheduler="inline", progress=False)
    assert stats.computed == 4 and stats.where == "inline"
    return results


def _same(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        pd.testing.assert_frame_equal(x, y)


def test_a_cohort_follows_the_study(inline):
    for c, table in enumerate(inline):
        kept = table[~table["excluded"]]
        assert len(kept) == 5 and (table["cohort"] == c).all()
        assert list(table["recruit"]) == list(range(len(table)))
        assert table.loc[table["excluded"], list(cp.FP_COLUMNS)].isna().all().all()
        fp = kept[list(cp.FP_COLUMNS)].to_numpy()
        assert np.all(fp >= 0) and np.allclose(fp * 2, np.round(fp * 2))  # the mean of two trials' counts
        assert set(table["kind"]) <= {k for k, _ in cp.MIXES["thesis"]}
    assert not all(a.equals(b) for a, b in zip(inline, inline[1:])), "cohorts must be independent draws"


def test_cohorts_depend_only_on_their_parameters(library, tasks, inline):
    again = [cp.simulate_cohort(t, *library) for t in reversed(tasks)][::-1]
    _same(again, inline)
    other = cp.simulate_cohort(cp.CohortTask(cp.CohortSetting(n_scenes=10, trial_seconds=3.0, quick_grid=True,
                                                              noise_scale=2.0), 0, 5), *library)
    assert not other["sigma"].equals(inline[0]["sigma"])


def test_prefixes_are_the_smaller_cohorts(inline):
    y5, y3 = ps.analysed_outcomes(inline, 5), ps.analysed_outcomes(inline, 3)
    assert np.array_equal(y5[:, :3], y3)
    with pytest.raises(ValueError, match="fewer than 6"):
        ps.analysed_outcomes(inline, 6)


def test_power_table_and_recommendations(inline):
    table = ps.power_table(inline, [3, 4, 5])
    assert set(table["n"]) == {3, 4, 5} and (table["cohorts"] == 4).all()
    assert ((table["ci_low"] <= table["power"]) & (table["power"] <= table["ci_high"])).all()
    gg = table[(table["test"] == "anova_gg") & (table["n"] == 5)].iloc[0]
    from mutual.study.rm_batch import rm_analyses
    assert gg["rejections"] == int(np.sum(rm_analyses(ps.analysed_outcomes(inline, 5)).p_gg < 0.05))
    rec = ps.recommendations(table)
    assert set(rec["test"]) == set(ps.KEY_TESTS) and (rec["largest n"] == 5).all()
    effect = ps.implied_effect(inline)
    assert effect["participants"] == 20 and 0 <= effect["eta2p"] < 1 and 0.5 - 1e-9 <= effect["epsilon"] <= 1 + 1e-9


def test_local_cluster_with_two_workers_gives_the_same_results(library, tasks, inline):
    results, stats = sweep.run_tasks(cp.simulate_cohort, tasks, shared=library, workers=2, progress=False)
    assert stats.workers == 2 and stats.computed == 4
    _same(results, inline)


def _wait_for(path, seconds=120):
    end = time.time() + seconds
    while time.time() < end:
        if path.exists() and path.stat().st_size > 0:
            try:
                return json.loads(path.read_text())["address"]
            except (json.JSONDecodeError, KeyError):
                pass
        time.sleep(0.2)
    raise TimeoutError(f"no scheduler file at {path}")


@pytest.fixture
def scheduler_by_address(tmp_path):
    """A scheduler and one worker started as separate processes, reached by address."""
    file = tmp_path / "scheduler.json"
    quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                               "--port", "0", "--no-dashboard", "--scheduler-file", str(file)], **quiet)]
    try:
        address = _wait_for(file)
        procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nworkers", "1",
                                       "--nthreads", "1", "--no-dashboard"], **quiet))
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def test_scheduler_by_address_gives_the_same_results(library, tasks, inline, scheduler_by_address, monkeypatch):
    monkeypatch.setenv(sweep.SCHEDULER_ENV, scheduler_by_address)
    results, stats = sweep.run_tasks(cp.simulate_cohort, tasks, shared=library, progress=False)
    assert stats.where == scheduler_by_address and stats.workers == 1
    _same(results, inline)


def test_the_cache_resumes_an_interrupted_sweep(library, tasks, inline, tmp_path):
    cache = sweep.TaskCache("v1", tmp_path / "cache")
    for t, r in zip(tasks[:2], inline[:2]):  # a sweep stopped after two cohorts
        cache.put(t.params(), r)
    results, stats = sweep.run_tasks(cp.simulate_cohort, tasks, shared=library, cache=cache, scheduler="inline",
                                     progress=False)
    assert (stats.cached, stats.computed) == (2, 2)
    _same(results, inline)
    cache.path(tasks[3].params()).write_bytes(b'{"format": 1, "key": ')  # a torn file is recomputed
    with pytest.warns(CacheWarning, match="does not verify"):
        results, stats = sweep.run_tasks(cp.simulate_cohort, tasks, shared=library, cache=cache, scheduler="inline",
                                         progress=False)
    assert (stats.cached, stats.computed) == (3, 1)
    _same(results, inline)
    assert not [p for p in (tmp_path / "cache").iterdir() if p.name.startswith(".")], "temporary files left behind"
    assert sweep.TaskCache("v2", tmp_path / "cache").get(tasks[0].params()) is None  # new code: recomputed


def test_seeds_follow_the_parameters_not_the_order():
    a, b = cp.CohortTask(TINY, 3, 5), cp.CohortTask(TINY, 3, 5)
    assert a.seed_sequence(0).generate_state(4).tolist() == b.seed_sequence(0).generate_state(4).tolist()
    assert cp.CohortTask(TINY, 4, 5).seed_sequence(0).generate_state(4).tolist() != a.seed_sequence(0).generate_state(4).tolist()
    assert cp.CohortSetting(mix="mostly-gradual").words() != cp.CohortSetting().words()


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
    """Wired into `mutual`, `mutual --help` still imports neither numpy nor jax (tests/test_cli.py's rule)."""
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


def test_explore_view_follows_its_inputs():
    small, large = power_plots.power_curve_view(f=0.2), power_plots.power_curve_view(f=0.6)
    y_small = small.axes[0].lines[0].get_ydata()
    y_large = large.axes[0].lines[0].get_ydata()
    assert np.all(y_large >= y_small) and y_large[9] > y_small[9] + 0.2
    labels = [t.get_text() for t in large.axes[0].get_legend().get_texts()]
    assert any(lbl.startswith("N = ") and "80%" in lbl for lbl in labels)
    assert os.environ.get("MPLBACKEND", "Agg")  # no pyplot figure was opened
    import matplotlib.pyplot as plt
    assert plt.get_fignums() == []
