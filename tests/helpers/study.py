"""Shared by the chapter 5 tests: the placeholders of the bad-input tables (the quick grid's library, a
member, a file) resolved when a case runs, a library's member by w_max, the power sweep's tiny cohort
setting, and comparing cohorts frame by frame."""

import pandas as pd

from mutual.study import cohort_power as cp
from mutual.study.teaming import Team
from mutual.supervision.supervisor import NoisySupervisor


class Lib:
    """Placeholder: the quick grid's library (``Lib()``), one member (``Lib(w)``) or the Conservative function."""

    def __init__(self, w=None, conservative=False, supervisor=None, team=None):
        self.w, self.conservative, self.supervisor, self.team = w, conservative, supervisor, team


class File:
    """Placeholder: a file in the test's temporary folder holding ``text``."""

    def __init__(self, text, name="data.csv"):
        self.text, self.name = text, name


def resolve(arg, tmp_path, functions):
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
        return [resolve(a, tmp_path, functions) for a in arg]
    return arg


def case_id(case):
    return f"{case[0].__name__}-{case[4][:40]}"


def member(library, w):
    return library[library.index_of(w)]


TINY = cp.CohortSetting(n_scenes=10, trial_seconds=3.0, quick_grid=True)


def assert_same_cohorts(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        pd.testing.assert_frame_equal(x, y)
