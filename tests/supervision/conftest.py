"""Fixtures shared by the chapter 4 tests: the quick grid's library of avoid value functions (computed once
per session into a private cache folder) and a module-wide cache folder."""

import numpy as np
import pytest

from mutual.supervision.reachability import QUICK_GRID, value_library

from helpers.supervision import RADIUS


W_MAXES = 0.25 * np.arange(1, 13)


@pytest.fixture(scope="session")
def library(tmp_path_factory):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MUTUAL_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "reachability-cache"))
        return value_library(W_MAXES, RADIUS, QUICK_GRID, progress=False)


@pytest.fixture(scope="module")
def cache(tmp_path_factory, monkeypatch_module):
    folder = tmp_path_factory.getbasetemp() / "reachability-cache"
    monkeypatch_module.setenv("MUTUAL_CACHE_DIR", str(folder))
    return folder


@pytest.fixture(scope="module")
def monkeypatch_module():
    with pytest.MonkeyPatch.context() as mp:
        yield mp
