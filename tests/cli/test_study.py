"""``mutual study anova`` end to end: on a fresh CSV against the textbook formulas, on the example, with names
read as text exactly as written (statsmodels' AnovaRM and pingouin's rm_anova on the same data as truth),
and on malformed or ambiguous files (exit 2, one line naming the file and the column; a table); the
statistics commands never import JAX."""

import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats
from statsmodels.stats.anova import AnovaRM

from mutual.cli import main
from mutual.inputs import read_csv as read_text_csv

from helpers.cli import EXAMPLES, MALFORMED, assert_one_line_error, mutual, no_temporaries, refuses_in_one_line


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
    assert {"anova_value+measure=false_positives.csv", "pairwise_value+measure=false_positives.csv",
            "means_value+measure=false_positives.png"} <= written


def test_study_anova_on_a_malformed_file_names_the_file_line_and_column(tmp_path):
    run = mutual("study", "anova", MALFORMED / "study_bad_value.csv", "--dv", "value", "--within", "treatment",
                 "--subject", "participant", cwd=tmp_path)
    assert_one_line_error(run, "study_bad_value.csv", "column 'value'", "line 7")
    assert not list(tmp_path.iterdir())


STUDY_TEXT = "who,cond,y\ns1,a,1\ns1,b,2\ns2,a,2\ns2,b,4\ns3,a,3\ns3,b,3.5\n"
ANOVA_ARGS = ["study", "anova", "data.csv", "--dv", "y", "--within", "cond", "--subject", "who"]


CASES = [
    # ---- study anova
    ({}, ANOVA_ARGS, ["data.csv: no such file"]),
    ({"data.csv": ""}, ANOVA_ARGS, ["data.csv", "the file is empty"]),
    ({"data.csv": "who,cond,y\n"}, ANOVA_ARGS, ["data.csv", "no data rows"]),
    ({"data.csv": b"\xff\xfe\x00w\x00h\x00o"}, ANOVA_ARGS, ["data.csv"]),
    ({"data.csv": STUDY_TEXT.replace("y\n", "score\n", 1)}, ANOVA_ARGS, ["data.csv", "missing column 'y'"]),
    ({"data.csv": STUDY_TEXT.replace("s2,b,4", "s2,b,four")}, ANOVA_ARGS, ["data.csv", "column 'y'", "line 5", "'four'"]),
    ({"data.csv": STUDY_TEXT.replace("s2,b,4", "s2,b,")}, ANOVA_ARGS, ["column 'y'", "line 5", "empty"]),
    ({"data.csv": STUDY_TEXT.replace("s3,a,3", ",a,3")}, ANOVA_ARGS, ["column 'who'", "line 6", "empty"]),
    ({"data.csv": STUDY_TEXT + "s3,b,4\n"}, ANOVA_ARGS, ["data.csv", "('s3', 'b')", "--aggregate mean"]),
    ({"data.csv": STUDY_TEXT.replace("s3,b,3.5\n", "")}, ANOVA_ARGS, ["data.csv", "unbalanced design", "s3"]),
    ({"data.csv": "who,cond,y\ns1,a,1\ns2,a,2\n"}, ANOVA_ARGS, ["data.csv", "at least 2"]),
    ({"data.csv": "who,cond,y\ns1,a,1\ns1,b,1\ns2,a,1\ns2,b,1\ns3,a,1\ns3,b,1\n"}, ANOVA_ARGS,
     ["data.csv", "'y' does not vary"]),
    ({"data.csv": STUDY_TEXT}, ANOVA_ARGS + ["--where", "cond"], ["--where 'cond'", "COL=VALUE"]),
    ({"data.csv": STUDY_TEXT}, ANOVA_ARGS + ["--where", "cond=z"], ["data.csv", "no row has cond = 'z'"]),
    ({"data.csv": STUDY_TEXT}, ANOVA_ARGS + ["--where", "phase=2"], ["data.csv", "missing column 'phase'"]),
    ({"data.csv": STUDY_TEXT}, ANOVA_ARGS + ["--levels", "a,c"], ["data.csv", "--levels", "no row has cond = 'c'"]),
    ({"data.csv": STUDY_TEXT}, ANOVA_ARGS + ["--levels", "a"], ["data.csv", "at least 2"]),
    ({"data.csv": STUDY_TEXT, "taken": "a file"}, ANOVA_ARGS + ["--out", "taken"], ["--out taken", "not a folder"]),
]


@pytest.mark.parametrize("files, argv, phrases", CASES, ids=[" ".join(c[1][:2]) + f" #{i}" for i, c in
                                                              enumerate(CASES)])
def test_bad_input_is_one_line_naming_what_is_wrong(files, argv, phrases, tmp_path):
    refuses_in_one_line(argv, files, phrases, tmp_path)


ROOT = Path(__file__).resolve().parents[2]
STUDY = ROOT / "data" / "examples" / "study.csv"


ANOVA = ["study", "anova", str(STUDY), "--dv", "value", "--within", "treatment", "--subject", "participant",
         "--where", "measure=false_positives", "--aggregate", "mean", "--no-progress"]


def test_a_100000_character_level_name_is_cut_in_the_figure(tmp_path, capsys):
    name = "x" * 100_000
    rows = [f"s{i},{lv},{(i * i * 1.7 + j * i) % 5}" for i in range(4) for j, lv in enumerate((name, "b"))]
    (tmp_path / "d.csv").write_text("s,l,y\n" + "\n".join(rows) + "\n")
    assert main(["study", "anova", str(tmp_path / "d.csv"), "--dv", "y", "--within", "l", "--subject", "s",
                 "--out", str(tmp_path / "o")]) == 0
    from PIL import Image
    assert Image.open(tmp_path / "o" / "means_y.png").size[0] < 2000      # 87 s and a huge figure before
    assert max(len(line) for line in capsys.readouterr().out.splitlines()) < 1000     # the name is cut


HEAVY = ("jax", "jaxlib", "hj_reachability", "cvxpy", "mutual.supervision", "mutual.motion", "mutual.constraints",
         "dask", "distributed")


PATHS = {
    "mutual --help": "from mutual.cli import build_parser; build_parser()",
    "import mutual.study": "import mutual.study, mutual.study.stats, mutual.study.power, mutual.study.data",
    "mutual study anova": f"from mutual.cli import main; assert main({ANOVA + ['--json', '--out', 'OUT']!r}) == 0",
    "mutual study power --analytic-only": "from mutual.cli import main; "
                                          "assert main(['study', 'power', '--analytic-only', '--out', 'OUT']) == 0",
    "mutual study power --f": "from mutual.cli import main; assert main(['study', 'power', '--f', '0.25', '--n', "
                              "'10', '--out', 'OUT']) == 0",
}


def test_statistics_commands_never_import_jax(tmp_path):
    """Each path, run one after another in one fresh process, leaves none of the heavy modules imported
    (checked after each, so a failure names the first path that imported one)."""
    check = f"import sys; print(PATH, sorted(m for m in {HEAVY!r} if m in sys.modules))"
    code = "\n".join(f"PATH = {path!r}\n{line}\n{check}" for path, line in PATHS.items())
    run = subprocess.run([sys.executable, "-c", code.replace("'OUT'", repr(str(tmp_path / "out")))],
                         capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    printed = [line for line in run.stdout.splitlines() if line.split(" [")[0] in PATHS]
    assert printed == [f"{path} []" for path in PATHS], "\n".join(printed)


FIXTURE = json.loads((Path(__file__).resolve().parents[1] / "data" / "pingouin_rm_anova.json").read_text())


def _anova(tmp_path, capsys, text, *extra, name="data.csv", encoding="utf-8"):
    """``mutual study anova`` on a file holding ``text``: (exit status, the --json object or the error line)."""
    path = tmp_path / name
    path.write_bytes(text.encode(encoding) if isinstance(text, str) else text)
    status = main(["study", "anova", str(path), "--dv", "y", "--within", "level", "--subject", "subject", "--json",
                   "--no-progress", "--out", str(tmp_path / "out"), *extra])
    out, err = capsys.readouterr()
    return status, (json.loads(out) if status == 0 else err.strip())


def _statsmodels(text, aggregate=False):
    """AnovaRM on the data with the names read as text; they are coded one to one ("s0", "s1", ...) because
    statsmodels' own design matrices drop names such as NaN and NA."""
    data = pd.read_csv(io.StringIO(text), dtype={"subject": str, "level": str}, keep_default_na=False)
    for column in ("subject", "level"):
        data[column] = [f"s{code}" for code in pd.factorize(data[column])[0]]
    row = AnovaRM(data, "y", "subject", within=["level"], aggregate_func="mean" if aggregate else None).fit()
    row = row.anova_table.iloc[0]
    return {"F": row["F Value"], "df1": row["Num DF"], "df2": row["Den DF"], "p": row["Pr > F"]}


def _long(subjects, levels, seed=0):
    rng = np.random.default_rng(seed)
    rows = [f"{s},{lv},{10 + j + rng.normal():.6f}" for s in subjects for j, lv in enumerate(levels)]
    return "subject,level,y\n" + "\n".join(rows) + "\n"


IDS_01_AND_1 = ("subject,level,y\n01,a,1\n01,a,3\n01,b,4\n01,b,4\n1,a,2\n1,a,2\n1,b,5\n1,b,6\n"
             "2,a,4\n2,a,4\n2,b,5\n2,b,7\n")


NAMES = [  # (case, CSV text, aggregate): each merged or refused by a reader that guesses types
    ("ids 01 and 1 are two people", IDS_01_AND_1, True),
    ("levels 1, 1.0, NA, None", _long(["s1", "s2", "s3", "s4", "s5"], ["1", "1.0", "NA", "None"]), False),
    ("levels 1 and 01", _long(["s1", "s2", "s3", "s4"], ["1", "01"], 1), False),
    ("levels -0, 0 and +0", _long(["s1", "s2", "s3", "s4"], ["-0", "0", "+0"], 2), False),
    ("levels 1e3 and 1000", _long(["s1", "s2", "s3", "s4"], ["1e3", "1000"], 3), False),
    ("ids that look missing", _long(["NA", "None", "null", "#N/A", "N/A", "nan", "NaN", "-"], ["u", "v"], 4), False),
    ("ids TRUE, true, FALSE", _long(["TRUE", "true", "FALSE", "False"], ["u", "v", "w"], 5), False),
    ("ids 1, 1.0, 1.00", _long(["1", "1.0", "1.00", "2"], ["u", "v"], 6), False),
    ("unicode names", _long(["Zoë", "Łukasz", "山田", "🤖"], ["α", "β", "γ"], 7), False),
    ("levels inf and Infinity", _long(["a", "b", "c"], ["inf", "Infinity"], 8), False),
]


@pytest.mark.parametrize("case, text, aggregate", NAMES, ids=[c[0] for c in NAMES])
def test_names_are_text_and_the_statistics_are_statsmodels(case, text, aggregate, tmp_path, capsys):
    status, r = _anova(tmp_path, capsys, text, *(["--aggregate", "mean"] if aggregate else []))
    assert status == 0, r
    truth = _statsmodels(text, aggregate)
    data = pd.read_csv(io.StringIO(text), dtype=str, keep_default_na=False)
    assert r["n_subjects"] == data["subject"].nunique()
    assert sorted(r["levels"]) == sorted(data["level"].unique())
    assert (r["df1"], r["df2"]) == (truth["df1"], truth["df2"])
    assert r["F"] == pytest.approx(truth["F"], rel=1e-9) and r["p"] == pytest.approx(truth["p"], rel=1e-9)


def test_ids_01_1_and_2_are_three_people(tmp_path, capsys):
    status, r = _anova(tmp_path, capsys, IDS_01_AND_1, "--aggregate", "mean")
    assert status == 0 and r["n_subjects"] == 3 and (r["df1"], r["df2"]) == (1, 2)


@pytest.mark.parametrize("name", sorted(FIXTURE["cases"]))
def test_the_anova_table_is_pingouins(name, tmp_path, capsys):
    case = FIXTURE["cases"][name]
    status, r = _anova(tmp_path, capsys, case["csv"])
    assert status == 0, r
    truth = case["pingouin"]
    ours = {"SS_effect": r["ss_effect"], "SS_error": r["ss_error"], "MS_effect": r["ms_effect"],
            "MS_error": r["ms_error"], "F": r["F"], "p": r["p"], "eps": r["eps"], "p_gg": r["p_gg"],
            "eta2p": r["eta2p"], "eta2g": r["eta2g"], "df1": r["df1"], "df2": r["df2"], "n_subjects": r["n_subjects"]}
    for key, value in truth.items():
        assert ours[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
    table = pd.read_csv(tmp_path / "out" / "anova_y.csv")
    for column in ("ss_effect", "ss_error", "ms_effect", "ms_error", "F", "p", "eps", "p_gg", "eta2p", "eta2g"):
        assert table[column].iloc[0] == r[column]          # the CSV reads back exactly what --json says


@pytest.mark.parametrize("ending, bom", [("\r\n", True), ("\r\n", False), ("\n", True), ("\r", False)])
def test_bom_and_line_endings(ending, bom, tmp_path, capsys):
    text = _long(["01", "1", "2", "3"], ["NA", "None"], 9)
    status, r = _anova(tmp_path, capsys, ("\ufeff" if bom else "") + text.replace("\n", ending))
    assert status == 0, r
    assert r["n_subjects"] == 4 and r["F"] == pytest.approx(_statsmodels(text)["F"], rel=1e-12)


AMBIGUOUS = [  # (case, CSV text, phrases of the one-line error)
    ("a duplicated header", "subject,level,y,y\na,u,1,2\n", ["'y' appears twice", "columns 3 and 4"]),
    ("a duplicated header with a space", "subject,level, y,y\na,u,1,2\n", ["'y' appears twice", "(as ' y')"]),
    ("a duplicated subject column", "subject,subject,level,y\na,b,u,1\n", ["'subject' appears twice"]),
    ("semicolons", "subject;level;y\na;u;1\n", ["seems to use ';' (semicolon)"]),
    ("tabs", "subject\tlevel\ty\na\tu\t1\n", ["seems to use a tab"]),
    ("pipes", "subject|level|y\na|u|1\n", ["seems to use '|'"]),
    ("ids ' 1' and '1'", "subject,level,y\n1,u,1\n1,v,2\n 1,u,2\n 1,v,4\n2,u,1\n2,v,3\n",
     ["column 'subject'", "'1' (line 2) and ' 1' (line 4)"]),
    ("levels 'u ' and 'u'", "subject,level,y\na,u,1\na,v,2\nb,u ,2\nb,v,4\n", ["column 'level'", "'u ' (line 4)"]),
    ("composed and decomposed é", "subject,level,y\na,\u00e9,1\na,v,2\nb,e\u0301,2\nb,v,4\n", ["column 'level'"]),
]


@pytest.mark.parametrize("case, text, phrases", AMBIGUOUS, ids=[c[0] for c in AMBIGUOUS])
def test_ambiguous_files_are_refused(case, text, phrases, tmp_path, capsys):
    status, err = _anova(tmp_path, capsys, text)
    assert status == 2 and len(err.splitlines()) == 1, err
    assert "data.csv" in err and all(p in err for p in phrases), err
    assert not (tmp_path / "out").exists()


def test_the_cli_tables_read_back_exactly(tmp_path, capsys):
    text = "subject,level,y\n" + "".join(f"s{i},{lv},{v!r}\n" for i in range(4) for lv, v in
                                         zip("ab", (1234567.0 + i / 3, 1e-7 * (i + 1) ** 0.5)))
    status, r = _anova(tmp_path, capsys, text)
    assert status == 0
    cells = read_text_csv(tmp_path / "out" / "cells_y.csv")
    data = pd.read_csv(io.StringIO(text), dtype={"subject": str})
    for _, row in data.iterrows():
        assert float(cells.set_index("subject").loc[row["subject"], row["level"]]) == row["y"]
