"""Running the benchmark (``benchmark.suite``): on an embedded two-worker Dask cluster the rows are those of one
process, in case order. The quick suite itself runs in notebook 09's quick run and is checked there
(tests/notebooks/test_chapter_results.py), the command line against the Python API on the same file."""

from mutual.constraints.continuous.benchmark import cases


def test_cases_on_a_two_worker_cluster_give_the_rows_of_one_process_in_case_order():
    """The cases are independent tasks: on an embedded Dask cluster of two workers, finishing in any order,
    the frame is the one a single process gives, row for row (the naive method: cheap, but every column)."""
    from mutual.constraints.continuous.benchmark import run_benchmark
    seen = []
    inline = run_benchmark("all", methods=("naive",), systems=["double_integrator"], scheduler="inline")
    spread = run_benchmark("all", methods=("naive",), systems=["double_integrator"], workers=2,
                           progress=lambda case, seconds: seen.append(case.id))
    assert list(spread["case"]) == [c.id for c in cases("all", ["double_integrator"])] == list(inline["case"])
    assert sorted(seen) == sorted(spread["case"])
    columns = [c for c in inline.columns if not c.endswith(": seconds")]
    assert spread[columns].equals(inline[columns])
