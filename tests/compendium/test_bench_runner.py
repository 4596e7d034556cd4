"""The benchmark framework (bench/run.py): what figures/benchmarks.md states, where each mode writes,
and that one failing module does not hide the others. Fake modules keep it fast; no timing is tested."""

import importlib.util
import textwrap

import pytest

from mutual.compendium.paths import BUILD, FIGURES, ROOT

spec = importlib.util.spec_from_file_location("bench_runner", ROOT / "bench" / "run.py")
bench = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench)

GOOD = '''
def run(quick=False):
    n = 10 if quick else 1000
    return [{"benchmark": "soft backup", "case": f"{n}x{n} grid", "seconds": 0.5, "baseline": "dense numpy",
             "baseline_seconds": 2.0, "compile_seconds": 1.25, "agree": "same ranking (float64)",
             "target": ">= 2x", "met": True},
            {"benchmark": "soft backup", "case": "exponent", "seconds": 0.1}]
'''
SILENT = '''
def run(quick=False):
    return [{"benchmark": "ilqr", "case": "N=100", "seconds": 1.0, "baseline": "L-BFGS", "baseline_seconds": 0.5}]
'''
BROKEN = '''
def run(quick=False):
    raise RuntimeError("no such solver")
'''


def test_quick_and_partial_runs_never_write_the_committed_table():
    assert bench.default_output(quick=False, names=[]) == FIGURES / "benchmarks.md"
    for quick, names in ((True, []), (True, ["ilqr"]), (False, ["ilqr"])):
        assert bench.default_output(quick, names).is_relative_to(BUILD)


def test_the_table_states_machine_versions_and_every_column(tmp_path, capsys):
    modules = tmp_path / "bench"
    modules.mkdir()
    for name, source in (("bench_a_good", GOOD), ("bench_b_silent", SILENT), ("bench_c_broken", BROKEN)):
        (modules / f"{name}.py").write_text(textwrap.dedent(source))
    out = tmp_path / "benchmarks.md"
    assert bench.main(["--quick", "--modules", str(modules), "--out", str(out)]) == 1  # one module failed
    text = out.read_text()
    for phrase in ("## Machine", "cores:", "load average at start", "## Versions", "python 3.", "numpy ", "jax ",
                   "| benchmark | case (problem, size) | seconds | baseline | baseline seconds | ratio | compile seconds "
                   "| agreement (how checked) | target | met |",
                   "| soft backup | 10x10 grid | 0.5 | dense numpy | 2 | 4 | 1.25 | same ranking (float64) | >= 2x | yes |",
                   "| soft backup | exponent | 0.1 |  |  |  | - |",
                   "ilqr / N=100: does not say whether the results agree",
                   "bench_c_broken: RuntimeError: no such solver",
                   "Wall time per module: bench_a_good", "quick (small sizes)"):
        assert phrase in text, f"{phrase!r} missing from:\n{text}"
    assert "benchmarks failed: bench_c_broken" in capsys.readouterr().err


def test_a_row_without_its_size_or_time_is_refused(tmp_path):
    modules = tmp_path / "bench"
    modules.mkdir()
    (modules / "bench_x.py").write_text("def run(quick=False):\n    return [{'benchmark': 'x', 'seconds': 1.0}]\n")
    table, _, failed = bench.collect(True, [], modules)
    assert "a row lacks ['case']" in failed["bench_x"]


@pytest.mark.parametrize("names, expected", [([], ["bench_alpha", "bench_beta"]), (["beta"], ["bench_beta"])])
def test_names_filter_the_modules(tmp_path, names, expected):
    for name in ("bench_alpha", "bench_beta"):
        (tmp_path / f"{name}.py").write_text(f"def run(quick=False):\n    return [{{'benchmark': '{name}', "
                                             "'case': 'c', 'seconds': 1.0}]\n")
    _, walls, _ = bench.collect(True, names, tmp_path)
    assert list(walls) == expected


def test_bench_and_bench_peers_each_replace_only_their_own_part_of_the_file():
    main_v1, main_v2 = "# Benchmarks\n\nold table\n", "# Benchmarks\n\nnew table\n"
    peers_v1, peers_v2 = "## Against the peers\n\nFDDP 1 ms\n", "## Against the peers\n\nFDDP 2 ms\n"
    text = bench.merge("", peers_v1, bench.PEERS)  # peers first, into no file
    assert text == "<!-- peers: begin -->\n" + peers_v1 + "<!-- peers: end -->\n"
    text = bench.merge(text, main_v1)  # then the main bench: the peers' section stays after it
    assert text.startswith(main_v1) and text.count("FDDP 1 ms") == 1
    text = bench.merge(text, peers_v2, bench.PEERS)  # the peers again: the main part stays
    assert "old table" in text and "FDDP 2 ms" in text and "FDDP 1 ms" not in text
    text = bench.merge(text, main_v2)
    assert "new table" in text and "old table" not in text and "FDDP 2 ms" in text
    assert text == main_v2 + "\n<!-- peers: begin -->\n" + peers_v2 + "<!-- peers: end -->\n"
    assert bench.merge(text, main_v2) == text  # a rerun changes nothing


def test_a_peers_run_writes_its_section_beside_the_main_table(tmp_path):
    modules = tmp_path / "bench"
    modules.mkdir()
    (modules / "bench_a_good.py").write_text(textwrap.dedent(GOOD))
    out = tmp_path / "benchmarks.md"
    out.write_text("# Benchmarks\n\nthe main table\n")
    assert bench.main(["--quick", "--peers", "--modules", str(modules), "--out", str(out)]) == 0
    text = out.read_text()
    assert text.startswith("# Benchmarks\n\nthe main table\n")
    for phrase in ("<!-- peers: begin -->\n## Against the peers (`make bench-peers`)", "### Machine", "### Timings",
                   "make bench-peers QUICK=1", "crocoddyl ", "casadi ", "pingouin ", "<!-- peers: end -->"):
        assert phrase in text, f"{phrase!r} missing from:\n{text}"
    assert bench.main(["--quick", "--modules", str(modules), "--out", str(out)]) == 0  # the main bench after it
    text = out.read_text()
    assert "the main table" not in text and text.count("<!-- peers: begin -->") == 1
    assert text.index("# Benchmarks") < text.index("<!-- peers: begin -->")
    assert bench.default_output(True, [], peers=True).is_relative_to(BUILD)
    assert bench.default_output(False, [], peers=True) == FIGURES / "benchmarks.md"
