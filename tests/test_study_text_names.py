"""Data read as the user wrote it (issue 22, section 1): subject and level names are text exactly as
written, ambiguous files are refused naming the duplicate, and written numbers read back exactly.

Truth: statsmodels' AnovaRM on the same data with the names kept as text, and pingouin's rm_anova
(values computed once in a scratch venv: tests/data/pingouin_rm_anova.py)."""

import io
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from statsmodels.stats.anova import AnovaRM

from mutual.cli import main
from mutual.inputs import format_exact, read_csv as read_text_csv
from mutual.study import paired_t_holm, read_table, rm_anova, write_table
from mutual.study.stats import greenhouse_geisser_epsilon

FIXTURE = json.loads((Path(__file__).parent / "data" / "pingouin_rm_anova.json").read_text())


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


# ---- names kept as text: the statistics statsmodels gives with the names as text --------------------

ISSUE_IDS = ("subject,level,y\n01,a,1\n01,a,3\n01,b,4\n01,b,4\n1,a,2\n1,a,2\n1,b,5\n1,b,6\n"
             "2,a,4\n2,a,4\n2,b,5\n2,b,7\n")

NAMES = [  # (case, CSV text, aggregate): each silently merged or refused before issue 22
    ("ids 01 and 1 (the issue's case)", ISSUE_IDS, True),
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


def test_the_issue_example_counts_three_people(tmp_path, capsys):
    status, r = _anova(tmp_path, capsys, ISSUE_IDS, "--aggregate", "mean")
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


# ---- ambiguous files are refused, naming the duplicate ---------------------------------------------

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


@pytest.mark.parametrize("columns", [["A", "B", "A"], ["A", "B", "A "], ["x", "x"]])
def test_wide_tables_with_a_repeated_level_are_refused(columns):
    wide = pd.DataFrame(np.random.default_rng(0).normal(size=(6, len(columns))), columns=columns)
    with pytest.raises(ValueError, match="'A'|'x'"):
        paired_t_holm(wide)
    with pytest.raises(ValueError, match="'A'|'x'"):
        greenhouse_geisser_epsilon(wide)


def test_the_library_loaders_read_text_and_refuse_duplicates(tmp_path):
    trials = tmp_path / "trials.csv"
    head = "participant,comparison,order,treatment,task_version,trial,measure,value\n"
    trials.write_text("\ufeff" + head + "NA,1-01,1,1,1,1,trips,3\nNA,1-01,2,01,2,2,trips,4\n"
                      "None,1-01,1,1,1,1,trips,2\nNone,1-01,2,01,2,2,trips,6\n")
    table = read_table(trials, "trials")
    assert sorted(table["participant"].unique()) == ["NA", "None"]
    assert sorted(table["treatment"].unique()) == ["01", "1"]
    trials.write_text(head.replace("value", "measure") + "a,x-y,1,x,1,1,trips,trips\n")
    with pytest.raises(ValueError, match="'measure' appears twice"):
        read_table(trials, "trials")
    demos = tmp_path / "demos.csv"
    demos.write_text("demo,t,state,state,action\n0,0,0,0,1\n")
    from mutual.constraints.demonstrations import load_demonstrations
    with pytest.raises(ValueError, match="'state' appears twice"):
        load_demonstrations(demos, mdp=None)


# ---- round trips lose nothing ------------------------------------------------------------------------

VALUES = [1234567.0, 0.1, 1 / 3, 2.0 ** 0.5, 1e-300, 5e-324, 1.7976931348623157e308, -0.0, 123456789012345.6, 15.0]


@pytest.mark.parametrize("value", VALUES)
def test_a_written_number_reads_back_exactly(value, tmp_path):
    frame = pd.DataFrame({"participant": ["p1"], "comparison": ["A-B"], "order": [1], "treatment": ["A"],
                          "task_version": [1], "trial": [1], "measure": ["anything"], "value": [value]})
    write_table(frame, tmp_path / "t.csv", "trials")
    back = read_table(tmp_path / "t.csv", "trials")["value"].iloc[0]
    assert back == value and np.signbit(back) == np.signbit(value)
    assert float(format_exact(value)) == value


def test_whole_numbers_keep_their_short_form(tmp_path):
    assert [format_exact(v) for v in (15.0, -3.0, 1e16, 0.5)] == ["15", "-3", "1e+16", "0.5"]


def test_the_cli_tables_read_back_exactly(tmp_path, capsys):
    text = "subject,level,y\n" + "".join(f"s{i},{lv},{v!r}\n" for i in range(4) for lv, v in
                                         zip("ab", (1234567.0 + i / 3, 1e-7 * (i + 1) ** 0.5)))
    status, r = _anova(tmp_path, capsys, text)
    assert status == 0
    cells = read_text_csv(tmp_path / "out" / "cells_y.csv")
    data = pd.read_csv(io.StringIO(text), dtype={"subject": str})
    for _, row in data.iterrows():
        assert float(cells.set_index("subject").loc[row["subject"], row["level"]]) == row["y"]


def test_the_simulated_study_tables_write_the_same_bytes():
    """write_table is exact now; the committed tables of whole counts and halves keep their bytes."""
    root = Path(__file__).resolve().parents[1] / "data"
    for name in ("ch5_simulated_phase3.csv", "ch5_illustrative_questionnaire.csv"):
        table = read_table(root / name, "trials")
        buffer = io.StringIO()
        table.to_csv(buffer, index=False, float_format=format_exact)
        assert buffer.getvalue() == (root / name).read_text()


def test_rm_anova_keeps_text_levels_in_memory():
    data = pd.DataFrame({"s": ["01", "01", "1", "1", "2", "2"], "l": ["NA", "None"] * 3, "y": [1.0, 3, 2, 5, 4, 5]})
    res = rm_anova(data, "y", "l", "s")
    assert res.n_subjects == 3 and res.levels == ("NA", "None")
