"""Malformed inputs to the chapter 5 study's public API and loaders (issue 13): each must raise the
named exception with a message that names the argument (or file, line and column) and the reason.

Table-driven: ``(callable, args, kwargs, exception, phrase)``. Arguments that need the quick grid's
value functions or a file are written as placeholders and resolved when the case runs.
"""

import numpy as np
import pandas as pd
import pytest

from mutual.study import explore
from mutual.study.cohort import (avoidance_onset, fraction_inside, learned_set_cluster, simulate_study,
                                 simulated_recruits, study_value_functions, write_simulated_study)
from mutual.study.data import illustrative_questionnaire, read_table, validate_trials, write_table
from mutual.study.design import balanced_latin_square, comparison_label, design_balance, study_design
from mutual.study.misalignment import straight_approach_starts, supervised_approaches
from mutual.study.published import (design_from_f_dofs, f_p_value, recover_from_summary, rounding_range,
                                    table_5_1_ratios)
from mutual.study.stats import (DegenerateDataError, greenhouse_geisser_epsilon, likert_vs_neutral, paired_t_holm,
                                rm_anova, significance_stars, tukey_from_summary, tukey_rm)
from mutual.study.teaming import Team, TeamingConfig, simulate_teaming, task_layout
from mutual.supervision.supervisor import NoisySupervisor


class Lib:
    """Placeholder: the quick grid's library (``Lib()``), one member (``Lib(w)``) or the Conservative function."""

    def __init__(self, w=None, conservative=False, supervisor=None, team=None):
        self.w, self.conservative, self.supervisor, self.team = w, conservative, supervisor, team


class File:
    """Placeholder: a file in the test's temporary folder holding ``text``."""

    def __init__(self, text, name="data.csv"):
        self.text, self.name = text, name


def _resolve(arg, tmp_path, functions):
    library, conservative = functions
    if isinstance(arg, Lib):
        if arg.conservative:
            return conservative
        if arg.supervisor is not None:
            return NoisySupervisor(library[library.index_of(arg.supervisor)], 0.3, 0.05)
        if arg.team is not None:
            return Team(library[library.index_of(arg.team)], 0.0)
        return library if arg.w is None else library[library.index_of(arg.w)]
    if isinstance(arg, File):
        path = tmp_path / arg.name
        path.write_text(arg.text)
        return path
    if isinstance(arg, list):
        return [_resolve(a, tmp_path, functions) for a in arg]
    return arg


def _long(values, levels=("a", "b", "c"), n=4):
    y = np.asarray(values, dtype=float).reshape(n, len(levels))
    return pd.DataFrame({"who": np.repeat([f"s{i}" for i in range(n)], len(levels)),
                         "cond": np.tile(levels, n), "y": y.ravel()})


GOOD = _long(np.arange(12) % 5 + np.repeat([0, 2, 1, 3], 3))
WIDE = pd.DataFrame({"a": [1.0, 2.0, 3.0, 5.0], "b": [2.0, 2.5, 4.5, 6.0], "c": [0.0, 1.0, 3.0, 2.0]})
HEADER = "participant,comparison,order,treatment,task_version,trial,measure,value\n"
ROW = "P01,Standard-Learned,1,Standard,1,1,{measure},{value}\n"
TRIALS_OK = HEADER + ROW.format(measure="false_positives", value=3)
LONG = "subj,cond,score\n1,a,3\n1,b,4\n2,a,x\n2,b,5\n"
IV_HEADER = "participant,trial,time,x,y,theta\n"
THESIS_TABLE = pd.DataFrame({"safe_set": ["Standard", "Learned"], "interventions_in_safe_set": [397, 220],
                             "interventions": [440, 440], "predicted_fp_vs_standard": [1, 0.554],
                             "average_fp": [12.54, 7.31], "observed_fp_vs_standard": [1, 0.583]})
means3 = {"S": 12.54, "L": 7.31, "C": 4.68}

CASES = [
    # --- rm_anova / cell_table: arguments and data
    (rm_anova, ([1, 2, 3], "y", "cond", "who"), {}, ValueError, "data must be a pandas DataFrame"),
    (rm_anova, (GOOD, "nope", "cond", "who"), {}, ValueError, "missing columns ['nope']"),
    (rm_anova, (GOOD, "y", "cond", "cond"), {}, ValueError, "three different columns"),
    (rm_anova, (GOOD, 5, "cond", "who"), {}, ValueError, "dv must name a column"),
    (rm_anova, (GOOD.iloc[:0], "y", "cond", "who"), {}, ValueError, "data has no rows"),
    (rm_anova, (GOOD.assign(y=GOOD["y"].where(GOOD.index != 4)), "y", "cond", "who"), {}, ValueError,
     "column 'y' has a missing value (NaN) in row 4"),
    (rm_anova, (GOOD.assign(y=GOOD["y"].astype(object).where(GOOD.index != 2, "many")), "y", "cond", "who"), {},
     ValueError, "column 'y' must be numeric: row 2 holds 'many'"),
    (rm_anova, (GOOD.assign(y=GOOD["y"].where(GOOD.index != 1, np.inf)), "y", "cond", "who"), {}, ValueError,
     "must hold finite numbers: row 1"),
    (rm_anova, (pd.concat([GOOD, GOOD.iloc[[0]]]), "y", "cond", "who"), {}, ValueError, "aggregate='mean'"),
    (rm_anova, (GOOD, "y", "cond", "who"), {"aggregate": "median"}, ValueError, "aggregate must be None or 'mean'"),
    (rm_anova, (GOOD.drop(index=5), "y", "cond", "who"), {}, ValueError, "unbalanced design: subject(s) ['s1']"),
    (rm_anova, (GOOD[GOOD.cond == "a"], "y", "cond", "who"), {}, ValueError, "need at least 2 subjects and 2 levels"),
    (rm_anova, (GOOD[GOOD.who == "s0"], "y", "cond", "who"), {}, ValueError, "got 1 subject(s)"),
    (rm_anova, (GOOD, "y", "cond", "who"), {"levels": ("a", "b")}, ValueError, "level(s) ['c'] not among levels"),
    (rm_anova, (GOOD, "y", "cond", "who"), {"levels": ("a", "b", "c", "d")}, ValueError, "level(s) ['d'] of levels have no rows"),
    (rm_anova, (GOOD, "y", "cond", "who"), {"levels": ("a", "a", "b", "c")}, ValueError, "must not repeat"),
    (rm_anova, (GOOD, "y", "cond", "who"), {"levels": "abc"}, ValueError, "levels must be a list of the levels of 'cond'"),
    # --- degenerate data: an error naming the measure and the reason, never NaN or a negative F
    (rm_anova, (GOOD.assign(y=0.0), "y", "cond", "who"), {}, DegenerateDataError,
     "'y' does not vary within subjects (every value is 0)"),
    (rm_anova, (GOOD.assign(y=7.5), "y", "cond", "who"), {}, DegenerateDataError, "every value is 7.5"),
    (rm_anova, (GOOD.assign(y=GOOD["who"].str[1].astype(float)), "y", "cond", "who"), {}, DegenerateDataError,
     "every subject has one value at every level"),
    (rm_anova, (GOOD.assign(y=GOOD["who"].str[1].astype(float) + GOOD["cond"].map({"a": 0, "b": 1, "c": 5})),
                "y", "cond", "who"), {}, DegenerateDataError, "zero residual variance"),
    (rm_anova, (pd.DataFrame({"participant": ["P1", "P1", "P2", "P2"], "treatment": ["A", "B"] * 2,
                              "measure": "collisions", "value": 0}), "collisions", "treatment", "participant"), {},
     DegenerateDataError, "'collisions' does not vary within subjects"),
    (likert_vs_neutral, ([5, 5, 5, 5],), {}, DegenerateDataError, "all 4 answers are 5"),
    (paired_t_holm, (WIDE.assign(d=WIDE["a"]),), {}, DegenerateDataError, "levels 'a' and 'd': the paired differences are identical"),
    (paired_t_holm, (WIDE.assign(d=WIDE["a"] + 2),), {}, DegenerateDataError, "the same for every subject (-2)"),
    (recover_from_summary, ({"S": 5.0, "L": 5.0, "C": 5.0}, 8.72, 2, 20), {}, DegenerateDataError, "all means are equal"),
    # --- the other statistics
    (likert_vs_neutral, ([4],), {}, ValueError, "at least 2 answers"),
    (likert_vs_neutral, ([4, 9, 3],), {}, ValueError, "whole numbers in 1..7"),
    (likert_vs_neutral, ([4, 5.5],), {}, ValueError, "whole numbers in 1..7"),
    (likert_vs_neutral, (["agree", "neutral"],), {}, ValueError, "answers must be numbers"),
    (likert_vs_neutral, ([4, 5, 3],), {"neutral": 9}, ValueError, "neutral must be a number in 1..7"),
    (paired_t_holm, (WIDE.assign(c=[1.0, np.nan, 2.0, 3.0]),), {}, ValueError, "complete table of finite numbers"),
    (paired_t_holm, ([1, 2, 3],), {}, ValueError, "cells must be a subject x level DataFrame"),
    (paired_t_holm, (WIDE[["a"]],), {}, ValueError, ">= 2 levels"),
    (paired_t_holm, (WIDE.assign(c=["x", "y", "z", "w"]),), {}, ValueError, "cells must hold numbers only"),
    (tukey_rm, (GOOD,), {}, ValueError, "pass an RMAnova, or long data with dv, within and subject"),
    (tukey_from_summary, ({"a": 1.0}, 1.0, 5), {}, ValueError, "at least 2 levels"),
    (tukey_from_summary, ({"a": 1.0, "b": float("nan")}, 1.0, 5), {}, ValueError, "level(s) ['b'] are not"),
    (tukey_from_summary, ({"a": 1.0, "b": 2.0}, 0.0, 5), {}, ValueError, "mse must be a positive finite number"),
    (tukey_from_summary, ({"a": 1.0, "b": 2.0}, 1.0, 1.5), {}, ValueError, "n must be an integer >= 2"),
    (greenhouse_geisser_epsilon, ([[1.0, 2.0]],), {}, ValueError, ">= 2 rows and columns"),
    (significance_stars, (float("nan"),), {}, ValueError, "p must be a probability in [0, 1]"),
    (f_p_value, (float("nan"), 2, 20), {}, ValueError, "F must be a finite number"),
    (f_p_value, (-1.0, 2, 20), {}, ValueError, "need F >= 0"),
    (design_from_f_dofs, (0, 20), {}, ValueError, "df_num must be an integer >= 1"),
    (design_from_f_dofs, (2, 21), {}, ValueError, "not a one-way repeated-measures design"),
    (recover_from_summary, (means3, 0.0, 2, 20), {}, ValueError, "F must be a positive finite number"),
    (recover_from_summary, ({"S": 1.0, "L": 2.0}, 8.72, 2, 20), {}, ValueError, "implies 3 levels, got 2 means"),
    (rounding_range, (means3, 8.72, 2, 20), {"decimals": -1}, ValueError, "decimals must be a whole number"),
    (table_5_1_ratios, (THESIS_TABLE.drop(columns="average_fp"),), {}, ValueError, "missing ['average_fp']"),
    (table_5_1_ratios, (THESIS_TABLE.assign(average_fp=[0.0, 1.0]),), {}, ValueError, "Standard row must have positive"),
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
    # --- the design
    (study_design, (0,), {}, ValueError, "n_participants must be a positive integer"),
    (study_design, (12,), {"treatments": ("a", "a", "b")}, ValueError, "three different names"),
    (study_design, (12,), {"treatments": ("a", "b")}, ValueError, "treatments must be three names"),
    (comparison_label, ("Standard", "Reckless"), {}, ValueError, "treatment 'Reckless' is not one of"),
    (comparison_label, ("Learned", "Learned"), {}, ValueError, "two different treatments"),
    (balanced_latin_square, (True,), {}, ValueError, "n must be a positive integer"),
    (design_balance, (pd.DataFrame({"participant": [1]}),), {}, ValueError, "design is missing columns"),
    # --- the simulated study
    (Team, (Lib(1.0), float("nan")), {}, ValueError, "alpha must be a finite number"),
    (Team, ("not a value function",), {}, ValueError, "value must be a mutual.supervision.reachability.ValueFunction"),
    (TeamingConfig, (), {"detection_prob": 1.5}, ValueError, "detection_prob must lie in [0, 1]"),
    (TeamingConfig, (), {"n_robots": 0}, ValueError, "n_robots must be a positive integer"),
    (TeamingConfig, (), {"n_robots": 2.5}, ValueError, "n_robots must be a positive integer"),
    (TeamingConfig, (), {"removal_cost": float("nan")}, ValueError, "removal_cost must be a finite number"),
    (TeamingConfig, (), {"obstacle_gap": -1.0}, ValueError, "obstacle_gap must be a non-negative number"),
    (task_layout, (1.5, TeamingConfig()), {}, ValueError, "version must be a non-negative whole number"),
    (simulate_teaming, ([], [], []), {}, ValueError, "non-empty and equally long"),
    (simulate_teaming, ([Lib(team=1.0)], ["a supervisor"], [1]), {}, ValueError, "supervisors[0] must be a NoisySupervisor"),
    (simulate_teaming, ([Lib(team=1.0)], [Lib(supervisor=1.0)], [1.5]), {}, ValueError, "versions[0] must be a whole number"),
    (simulate_teaming, ([Lib(team=1.0)], [Lib(supervisor=1.0)], [1]), {"record": 3}, ValueError, "record must index a trial"),
    (simulate_study, (Lib(), Lib(conservative=True)), {"kinds": ("standard-like", "bogus")}, ValueError,
     "unknown participant kind(s) ['bogus']"),
    (simulate_study, (Lib(), Lib(conservative=True)), {"kinds": "gradual"}, ValueError, "kinds must be a non-empty list"),
    (simulate_study, (Lib(), Lib(conservative=True)), {"n_scenes": 1}, ValueError, "n_scenes must be an integer >= 2"),
    (simulate_study, (Lib(), Lib(conservative=True)), {"kinds": ("agile", "agile"), "n_scenes": 10}, ValueError,
     "all 2 simulated recruits were excluded"),
    (simulate_study, (Lib(1.0), Lib(conservative=True)), {}, ValueError, "library must be a"),
    (simulated_recruits, (Lib(),), {"sigma_range": (0.1, 0.05)}, ValueError, "sigma_range must satisfy 0 <= low <= high"),
    (learned_set_cluster, (float("nan"), 0.3), {}, ValueError, "w_max must be a finite number"),
    (fraction_inside, (Lib(1.0), [[np.nan, 0.0, 0.0]]), {}, ValueError, "states contains NaN"),
    (fraction_inside, (Lib(1.0), [[1.0, 0.0, 0.0]]), {"level": float("inf")}, ValueError, "level must be a finite number"),
    (avoidance_onset, (Lib(1.0),), {"level": -5.0}, ValueError, "never meets {V < -5}"),
    (write_simulated_study, ("not a study", "/tmp"), {}, ValueError, "must be a simulated Study"),
    (straight_approach_starts, (0, np.random.default_rng(0)), {}, ValueError, "n must be a positive integer"),
    (supervised_approaches, (Lib(1.0), 0.0, Lib(supervisor=0.5), [[0.0, 0.0]], np.random.default_rng(0)), {},
     ValueError, "starts must be a finite (n, 3) array"),
    (supervised_approaches, (Lib(1.0), 0.0, "supervisor", [[-7.0, 0.0, 0.0]], np.random.default_rng(0)), {},
     ValueError, "supervisor must be a NoisySupervisor"),
    # --- the Explore views
    (explore.cohort_view, (), {"n_standard": -1}, ValueError, "n_standard must be an integer in 0..50"),
    (explore.cohort_view, (), {"n_standard": 1, "n_conservative": 0, "n_gradual": 0, "n_agile": 0}, ValueError,
     "at least 2 recruits"),
    (explore.cohort_view, (), {"noise": float("nan")}, ValueError, "noise must be a finite number in [0, 1]"),
    (explore.misalignment_view, (), {"w_supervisor": 0.9}, ValueError, "w_supervisor must be one of the library's"),
    (explore.misalignment_view, (), {"k": 10}, ValueError, "k must be a number in [-3, 5]"),
]


def _case_id(case):
    return f"{case[0].__name__}-{case[4][:40]}"


@pytest.fixture(scope="module")
def functions():
    return study_value_functions(quick=True)


@pytest.mark.parametrize("function, args, kwargs, exception, phrase", CASES, ids=[_case_id(c) for c in CASES])
def test_bad_input_is_named(function, args, kwargs, exception, phrase, tmp_path, functions):
    args = [_resolve(a, tmp_path, functions) for a in args]
    with pytest.raises(exception) as info:
        function(*args, **kwargs)
    assert phrase in str(info.value)


def test_degenerate_errors_are_value_errors():
    """One ``except ValueError`` catches every refusal of the study's statistics."""
    assert issubclass(DegenerateDataError, ValueError)


def test_suite_size():
    assert len(CASES) >= 35
