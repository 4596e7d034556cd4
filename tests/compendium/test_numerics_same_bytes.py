"""The same bytes on another machine: numpy's CPU dispatch (AVX-512 SVML ``arctan2``, ``exp``, ``log``) moved
Fig. 5.2 and 5.5 by a few pixels between machines, so the runner pins numpy's dispatch to what an AVX2
machine computes; figures are checked on one and two threads, and roundoff noise is written as a bound."""

import hashlib
import json
import os
import platform
import subprocess
import sys

import pytest

from mutual.compendium.numerics import portable_env

FIGURES_5_2_AND_5_5 = """
import json, os
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
from mutual.compendium.figures import savefig, use_style
from mutual.study import cohort, plots, teaming

use_style()
library, conservative = cohort.study_value_functions(quick=True)
study = cohort.simulate_study(library, conservative, n_scenes=8, config=teaming.TeamingConfig(duration=12.0), seed=0,
                              kinds=cohort.RECRUIT_KINDS[:6])
people = study.participants
analysed = people[~people.excluded]
fit = study.fits[analysed.participant.iloc[0]]
fig, axes = plt.subplots(1, 3, figsize=(9.5, 3.6), sharey=True, layout="constrained")
for ax, (vf, level) in zip(axes, [(study.standard, 0.0), (fit.value_fn, fit.mu), (conservative, 0.0)]):
    plots.plot_reachable(ax, vf, level)
savefig(fig, "fig_5_2")
fig, ax = plt.subplots(figsize=(5.8, 4.4))
for row in analysed.itertuples():
    plots.plot_reachable(ax, study.fits[row.participant].value_fn, row.mu_hat, fill=False)
savefig(fig, "fig_5_5")
states = study.interventions[["x", "y", "theta"]].to_numpy()
numbers = {"mu_hat": [float(m).hex() for m in people.mu_hat], "states": [float(v).hex() for v in states.ravel()],
           "threads": os.environ["OMP_NUM_THREADS"]}
with open(os.path.join(os.environ["MUTUAL_OUTPUT_DIR"], "numbers.json"), "w") as handle:
    json.dump(numbers, handle)
"""

THREADS = {  # the thread settings of a 1-core and of a 2-core machine
    1: {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
        "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"},
    2: {"OMP_NUM_THREADS": "2", "OPENBLAS_NUM_THREADS": "2", "MKL_NUM_THREADS": "2", "XLA_FLAGS": ""},
}


def _start(tmp_path, threads):
    """The figures' program in a process of its own with ``threads``' settings, writing to its own folder."""
    out = tmp_path / f"threads-{threads}"
    out.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("NPY_DISABLE_CPU_FEATURES", "OPENBLAS_CORETYPE")}
    env.update(THREADS[threads])
    env = {**env, **portable_env(env), "MUTUAL_OUTPUT_DIR": str(out), "SOURCE_DATE_EPOCH": "0"}
    return subprocess.Popen([sys.executable, "-c", FIGURES_5_2_AND_5_5], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True), out


def _finish(proc, out):
    stderr = proc.communicate(timeout=600)[1]
    assert proc.returncode == 0, stderr[-3000:]
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(out.iterdir())}, out


def test_figures_5_2_and_5_5_are_the_same_bytes_on_one_and_two_threads(tmp_path):
    started = [_start(tmp_path, threads) for threads in (1, 2)]     # side by side: two processes, two folders
    (one, out_one), (two, out_two) = [_finish(*run) for run in started]
    numbers = json.loads((out_one / "numbers.json").read_text()), json.loads((out_two / "numbers.json").read_text())
    assert numbers[0]["threads"] == "1" and numbers[1]["threads"] == "2"
    assert numbers[0]["mu_hat"] == numbers[1]["mu_hat"] and numbers[0]["states"] == numbers[1]["states"]
    del one["numbers.json"], two["numbers.json"]
    assert sorted(one) == ["fig_5_2.pdf", "fig_5_2.png", "fig_5_5.pdf", "fig_5_5.png"]
    assert one == two, {name: (one[name][:8], two[name][:8]) for name in one if one[name] != two.get(name)}


x86_with_avx2 = pytest.mark.skipif(platform.machine().lower() not in ("x86_64", "amd64") or not portable_env({}),
                                   reason="the pin is for x86-64 CPUs with AVX2")


@x86_with_avx2
def test_the_pin_names_numpy_dispatch_beyond_avx2_and_openblas_haswell():
    pinned = portable_env({})
    assert pinned["OPENBLAS_CORETYPE"] == "Haswell"
    assert all(t.startswith(("X86_V4", "AVX512", "AMX")) for t in pinned["NPY_DISABLE_CPU_FEATURES"].split())
    assert "X86_V3" not in pinned["NPY_DISABLE_CPU_FEATURES"].split()
    assert portable_env({"OPENBLAS_CORETYPE": "SkylakeX"}).get("OPENBLAS_CORETYPE") is None   # a value of one's own wins


@x86_with_avx2
def test_the_pin_makes_numpy_compute_what_an_avx2_machine_computes():
    """arctan2 and exp as numpy computes them here with the pin and with AVX-512 switched off by hand
    (an AVX2 machine): the same bits."""
    program = ("import numpy as np, hashlib; x = np.random.default_rng(0).uniform(-10, 10, 4096); "
               "print(hashlib.sha256(np.arctan2(np.sin(x), np.cos(x)).tobytes() + np.exp(x).tobytes()"
               " + np.log(np.abs(x)).tobytes()).hexdigest())")
    base = {k: v for k, v in os.environ.items() if k not in ("NPY_DISABLE_CPU_FEATURES", "OPENBLAS_CORETYPE")}
    pinned = {**base, **portable_env(base)}
    avx2 = {**base, "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512F AVX512_SKX AVX512_CLX AVX512_CNL AVX512_ICL "
                                                "AVX512_SPR"}
    outputs = [subprocess.run([sys.executable, "-c", program], env=env, capture_output=True, text=True,
                              check=True).stdout for env in (pinned, avx2)]
    assert outputs[0] == outputs[1]


def test_the_runner_starts_kernels_with_the_pin(tmp_path, monkeypatch):
    import nbformat
    from mutual.compendium.notebooks import execute
    monkeypatch.setenv("MUTUAL_OUTPUT_DIR", str(tmp_path / "out"))
    monkeypatch.delenv("OPENBLAS_CORETYPE", raising=False)
    monkeypatch.delenv("NPY_DISABLE_CPU_FEATURES", raising=False)
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "mutual", "display_name": "Python (mutual)", "language": "python"}
    nb.cells = [nbformat.v4.new_code_cell("quick = False"),
                nbformat.v4.new_code_cell("import os\nprint(os.environ.get('OPENBLAS_CORETYPE'), "
                                          "os.environ.get('NPY_DISABLE_CPU_FEATURES'))")]
    nb.cells[0].metadata["tags"] = ["parameters"]
    path = tmp_path / "99_pin.ipynb"
    nbformat.write(nb, path)
    ran = execute(path, {"quick": True})
    pinned = portable_env({})
    expected = f"{pinned.get('OPENBLAS_CORETYPE')} {pinned.get('NPY_DISABLE_CPU_FEATURES')}\n"
    printed = [o["text"] for c in ran.cells if c.cell_type == "code" for o in c.outputs if "text" in o]
    assert printed == [expected]


# -- round-off-level quantities as bounds ---------------------------------------------------------------

from mutual.compendium.results import roundoff  # noqa: E402


@pytest.mark.parametrize("value, floor, fmt, text", [
    (3.6e-15, 1e-12, ".2g", "< 1e-12"),      # the chapter 2 gap of the review (2.4e-15 on the other machine)
    (2.4e-15, 1e-12, ".2g", "< 1e-12"),
    (7.5e-17, 1e-12, ".2g", "< 1e-12"),      # the KL (1.31e-16 there)
    (9.2e-11, 1e-8, ".2g", "< 1e-8"),        # the L-BFGS gap (7.1e-11 there): an optimiser's floor
    (-2e-17, 1e-12, "+.4f", "< 1e-12"),      # a signed quantity: no "+0.0000" that flips to "-0.0000"
    (0.0, 1e-12, ".2g", "< 1e-12"),
    (0.0123, 1e-12, "+.4f", "+0.0123"),      # a result, not noise: printed as asked
    (2.7e-12, 2.5e-12, ".2g", "2.7e-12"),
    (1e-13, 2.5e-12, ".2g", "< 2.5e-12"),
])
def test_roundoff_writes_noise_as_a_bound(value, floor, fmt, text):
    assert roundoff(value, floor, fmt) == text


@pytest.mark.parametrize("value, floor", [(float("nan"), 1e-12), (float("inf"), 1e-12), (1e-20, 0.0), (1e-20, -1.0),
                                          ("1e-20", 1e-12), (True, 1e-12), (1e-20, float("nan"))])
def test_roundoff_refuses_what_is_not_a_finite_number(value, floor):
    with pytest.raises(ValueError, match="roundoff"):
        roundoff(value, floor)


def test_a_table_writes_roundoff_cells_as_bounds(tmp_path, monkeypatch):
    import pandas as pd
    from mutual.compendium.figures import save_table
    monkeypatch.setenv("MUTUAL_OUTPUT_DIR", str(tmp_path))
    table = pd.DataFrame({"dynamics": ["slip 0.1", "deterministic"], "trajectories": [157464, 157464],
                          "KL": [4.86, 7.5e-17], "gap": [0.559, 2.78e-16]})
    other_machine = table.assign(KL=[4.86, 1.31e-16], gap=[0.559, 1.1e-16])
    csv, md = save_table(table, "table_9_roundoff", roundoff=1e-12)
    first = csv.read_bytes(), md.read_bytes()
    save_table(other_machine, "table_9_roundoff", roundoff=1e-12)
    assert (csv.read_bytes(), md.read_bytes()) == first
    assert "deterministic,157464,< 1e-12,< 1e-12" in first[0].decode() and "| 4.86 | 0.559 |" in first[1].decode()
