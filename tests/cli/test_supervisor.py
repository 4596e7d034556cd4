"""``mutual supervisor fit`` end to end: it recovers a freshly simulated supervisor, the example's supervisors
(also by the closed form), and refuses malformed files (exit 2, one line naming the file, the line and the
column; a table)."""

import json

import numpy as np
import pandas as pd
import pytest


from helpers.cli import EXAMPLES, MALFORMED, assert_one_line_error, mutual, refuses_in_one_line


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


INTERVENTIONS = (EXAMPLES / "interventions.csv").read_text() if (EXAMPLES / "interventions.csv").exists() else ""


CASES = [
    # ---- supervisor fit (all refused before any value function is computed)
    ({}, ["supervisor", "fit", "i.csv"], ["i.csv: no such file"]),
    ({"i.csv": INTERVENTIONS.replace("theta", "heading", 1)}, ["supervisor", "fit", "i.csv"],
     ["i.csv", "missing column 'theta'"]),
    ({"i.csv": INTERVENTIONS.replace("sim-02,0,", "sim-02,0.5,", 1)}, ["supervisor", "fit", "i.csv"],
     ["i.csv", "column 'trial'", "0.5"]),
    ({"i.csv": INTERVENTIONS.replace("sim-03,", ",", 1)}, ["supervisor", "fit", "i.csv"],
     ["i.csv", "column 'participant'", "empty"]),
    ({"i.csv": INTERVENTIONS + "sim-04,1,-2,1,1,0,0,0\n"}, ["supervisor", "fit", "i.csv"],
     ["i.csv", "line 92", "column 'time'", "negative"]),
    ({"i.csv": INTERVENTIONS + "sim-04,1,2,1,1,0,0,0,9\n"}, ["supervisor", "fit", "i.csv"], ["i.csv"]),
    ({"i.csv": INTERVENTIONS}, ["supervisor", "fit", "i.csv", "--participant", "nobody"],
     ["i.csv", "no intervention of participant 'nobody'"]),
    ({"i.csv": INTERVENTIONS}, ["supervisor", "fit", "i.csv", "--pool", "--participant", "sim-01"],
     ["--pool and --participant"]),
    ({"i.csv": INTERVENTIONS}, ["supervisor", "fit", "i.csv", "--w-max", "0.5,fast"], ["--w-max '0.5,fast'"]),
    ({"i.csv": INTERVENTIONS}, ["supervisor", "fit", "i.csv", "--w-max", "1"], ["--w-max '1'", "two members"]),
    ({"i.csv": INTERVENTIONS}, ["supervisor", "fit", "i.csv", "--level", "inf"], ["--level inf"]),
]


@pytest.mark.parametrize("files, argv, phrases", CASES, ids=[" ".join(c[1][:2]) + f" #{i}" for i, c in
                                                              enumerate(CASES)])
def test_bad_input_is_one_line_naming_what_is_wrong(files, argv, phrases, tmp_path):
    refuses_in_one_line(argv, files, phrases, tmp_path)
