"""Fixtures shared by the chapter 5 tests: the quick grid's value functions of the simulated study, pingouin's
``pairwise_tests`` dataset and an illustrative questionnaire, and the power sweep's tiny cohorts."""

import io

import pandas as pd
import pytest

from mutual.study import cohort, cohort_power as cp, sweep
from mutual.study.cohort import study_value_functions
from mutual.study.data import illustrative_questionnaire
from mutual.study.design import study_design

from helpers.study import TINY


@pytest.fixture(scope="session")
def functions():
    return study_value_functions(quick=True)


PAIRWISE_TESTS = """Subject,Gender,Drug,Scores
1,M,A,4
2,M,A,5
3,M,A,3
4,M,A,4
5,M,A,2
6,M,A,7
7,F,A,5
8,F,A,4
9,F,A,2
10,F,A,3
11,F,A,5
1,M,B,6
2,M,B,4
3,M,B,8
4,M,B,9
5,M,B,4
6,M,B,5
7,F,B,6
8,F,B,4
9,F,B,5
10,F,B,1
11,F,B,4
1,M,C,5
2,M,C,6
3,M,C,6
4,M,C,4
5,M,C,5
6,M,C,4
7,F,C,4
8,F,C,5
9,F,C,4
10,F,C,4
11,F,C,7
"""


@pytest.fixture
def pairwise():
    return pd.read_csv(io.StringIO(PAIRWISE_TESTS))


@pytest.fixture
def questionnaire():
    return illustrative_questionnaire(study_design(12), seed=3)


@pytest.fixture(scope="session")
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
