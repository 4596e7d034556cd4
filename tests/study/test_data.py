"""The study tables and their loaders: a table round-trips, names are read as text exactly as written and a
duplicate is refused, the simulated study's committed tables read back as the same bytes; what a loader
refuses names the file, the line and the column (a table)."""

import io
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from mutual.inputs import format_exact
from mutual.study.data import illustrative_questionnaire, read_table, validate_trials, write_table
from mutual.study.stats import rm_anova

from helpers.study import File, case_id, resolve


def test_study_table_round_trip(tmp_path, questionnaire):
    path = write_table(questionnaire, tmp_path / "q.csv", "trials")
    back = read_table(path, "trials")
    pd.testing.assert_frame_equal(back, questionnaire.reset_index(drop=True), check_dtype=False)


@pytest.mark.parametrize("corrupt, message", [
    (lambda d: d.drop(columns="trial"), "missing column 'trial'"),
    (lambda d: d.assign(value=d["value"].where(d.index != 7)), "row 7, column 'value': empty"),
    (lambda d: pd.concat([d, d.iloc[[4]]]), "duplicate"),
    (lambda d: d.assign(value=d["value"].where(d.index != 2, 9)), "Likert"),
    (lambda d: d.assign(treatment=d["treatment"].where(d.index != 0, "Reckless")), "does not name this row's treatment"),
])
def test_bad_study_data_raises(questionnaire, corrupt, message):
    with pytest.raises(ValueError, match=message):
        validate_trials(corrupt(questionnaire))


def test_read_table_accepts_any_treatment_names(tmp_path, questionnaire):
    renamed = questionnaire.replace({"Standard": "baseline", "Learned": "our-method", "Conservative": "cautious"})
    renamed["comparison"] = renamed["comparison"].str.replace("Standard", "baseline").str.replace(
        "Learned", "our-method").str.replace("Conservative", "cautious")
    path = write_table(renamed, tmp_path / "t.csv", "trials")
    back = read_table(path, "trials")
    assert set(back["treatment"]) == {"baseline", "our-method", "cautious"}
    res = rm_anova(back, "trust", "treatment", "participant", aggregate="mean")
    assert res.levels == ("baseline", "cautious", "our-method")
    with pytest.raises(ValueError, match="line 2, column 'treatment': unknown treatment"):
        read_table(path, "trials", treatments=("Standard", "Learned", "Conservative"))


def test_read_long_table(tmp_path):
    path = tmp_path / "long.csv"
    path.write_text("subj,cond,score,extra\n1,a,3.5,x\n1,b,4,y\n2,a,2,z\n2,b,5.5,w\n3,a,1,q\n3,b,2.5,r\n")
    data = read_table(path, "long", dv="score", within="cond", subject="subj")
    res = rm_anova(data, "score", "cond", "subj")
    assert res.n_subjects == 3 and res.df1 == 1
    assert res.p == pytest.approx(stats.ttest_rel([3.5, 2, 1], [4, 5.5, 2.5]).pvalue)


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


VALUES = [1234567.0, 0.1, 1 / 3, 2.0 ** 0.5, 1e-300, 5e-324, 1.7976931348623157e308, -0.0, 123456789012345.6, 15.0]


@pytest.mark.parametrize("value", VALUES)
def test_a_written_number_reads_back_exactly(value, tmp_path):
    frame = pd.DataFrame({"participant": ["p1"], "comparison": ["A-B"], "order": [1], "treatment": ["A"],
                          "task_version": [1], "trial": [1], "measure": ["anything"], "value": [value]})
    write_table(frame, tmp_path / "t.csv", "trials")
    back = read_table(tmp_path / "t.csv", "trials")["value"].iloc[0]
    assert back == value and np.signbit(back) == np.signbit(value)
    assert float(format_exact(value)) == value


def test_the_simulated_study_tables_write_the_same_bytes():
    """write_table is exact now; the committed tables of whole counts and halves keep their bytes."""
    root = Path(__file__).resolve().parents[2] / "data"
    for name in ("ch5_simulated_phase3.csv", "ch5_illustrative_questionnaire.csv"):
        table = read_table(root / name, "trials")
        buffer = io.StringIO()
        table.to_csv(buffer, index=False, float_format=format_exact)
        assert buffer.getvalue() == (root / name).read_text()


HEADER = "participant,comparison,order,treatment,task_version,trial,measure,value\n"
ROW = "P01,Standard-Learned,1,Standard,1,1,{measure},{value}\n"
TRIALS_OK = HEADER + ROW.format(measure="false_positives", value=3)
LONG = "subj,cond,score\n1,a,3\n1,b,4\n2,a,x\n2,b,5\n"
IV_HEADER = "participant,trial,time,x,y,theta\n"


CASES = [
    # --- loaders: the file, the line and the column
    (read_table, (File(""),), {}, ValueError, "data.csv: the file is empty"),
    (read_table, (File(HEADER),), {}, ValueError, "data.csv: no data rows after the header"),
    (read_table, (File(TRIALS_OK.replace(",value", ",score")),), {}, ValueError, "data.csv: missing column 'value'"),
    (read_table, (File(TRIALS_OK + ROW.format(measure="trust", value="lots").replace(",1,1,", ",2,2,")),), {},
     ValueError, "data.csv, line 3, column 'value': 'lots' is not a number"),
    (read_table, (File(TRIALS_OK.replace(",1,Standard,", ",3,Standard,")),), {}, ValueError,
     "line 2, column 'order': '3' is not 1 or 2"),
    (read_table, (File(TRIALS_OK.replace(",1,1,", ",1,1.5,")),), {}, ValueError, "line 2, column 'trial': '1.5' is not a whole number"),
    (read_table, (File(HEADER + ROW.format(measure="trust", value=9)),), {}, ValueError,
     "line 2, column 'value': 9 is not a Likert answer"),
    (read_table, (File(TRIALS_OK + ROW.format(measure="collisions", value=-1)),), {}, ValueError,
     "line 3, column 'value': -1 is not a count"),
    (read_table, (File(TRIALS_OK.replace(",3\n", ",\n")),), {}, ValueError, "line 2, column 'value': empty"),
    (read_table, (File(TRIALS_OK + TRIALS_OK[len(HEADER):]),), {}, ValueError, "line 3: duplicate row"),
    (read_table, (File(TRIALS_OK.replace("Standard-Learned", "Learned-Conservative")),), {}, ValueError,
     "line 2, column 'comparison': 'Learned-Conservative' does not name this row's treatment 'Standard'"),
    (read_table, (File(TRIALS_OK),), {"treatments": ("A", "B")}, ValueError, "line 2, column 'treatment': unknown treatment"),
    (read_table, (File(TRIALS_OK + "P01,Standard-Learned,1,Standard,1\n"),), {}, ValueError, "line 3: the row has 5 fields, the header 8"),
    (read_table, (File('a,b\n1,"unclosed\n'),), {}, ValueError, "not a readable CSV file"),
    (read_table, (File(TRIALS_OK),), {"kind": "survey"}, ValueError, "kind must be one of"),
    (read_table, (File(TRIALS_OK),), {"treatments": "Standard"}, ValueError, "treatments must be a list of names"),
    (illustrative_questionnaire, (pd.DataFrame({"participant": [1]}),), {}, ValueError, "design must be a DataFrame with columns"),
    (read_table, (File(TRIALS_OK),), {"kind": "trials", "dv": "value"}, ValueError, "takes no option(s) ['dv']"),
    (read_table, (File(LONG),), {"kind": "long", "dv": "score"}, ValueError, "needs dv=, within= and subject="),
    (read_table, (File(LONG),), {"kind": "long", "dv": "score", "within": "cond", "subject": "subj"}, ValueError,
     "line 4, column 'score': 'x' is not a number"),
    (read_table, (File(LONG),), {"kind": "long", "dv": "rating", "within": "cond", "subject": "subj"}, ValueError,
     "missing column 'rating'"),
    (read_table, (File(IV_HEADER + "P01,0,1.5,1,2,0\nP01,1,2.0,west,2,0\n"),), {"kind": "interventions"}, ValueError,
     "line 3, column 'x': 'west' is not a finite number"),
    (read_table, (File(IV_HEADER + "P01,0,-1,1,2,0\n"),), {"kind": "interventions"}, ValueError,
     "line 2, column 'time': '-1' is not a non-negative number of seconds"),
    (read_table, ("/nonexistent/study.csv",), {}, FileNotFoundError, "no such file"),
    (read_table, (42,), {}, ValueError, "path must be a file path"),
    (write_table, (pd.DataFrame({"participant": ["P1"]}), "/tmp/never-written.csv"), {}, ValueError,
     "trials table: missing column 'comparison'"),
    (validate_trials, (pd.DataFrame({c: [1] for c in HEADER.strip().split(",")}),), {"treatments": ("x",)},
     ValueError, "trial table, row 0, column 'treatment': unknown treatment '1'"),
]


@pytest.mark.parametrize("function, args, kwargs, exception, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_is_named(function, args, kwargs, exception, phrase, tmp_path, functions):
    args = [resolve(a, tmp_path, functions) for a in args]
    with pytest.raises(exception) as info:
        function(*args, **kwargs)
    assert phrase in str(info.value)
