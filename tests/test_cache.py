"""Caches that cannot run code and heal (``mutual.cache``, as the power sweep's task cache uses it): nothing in
the package unpickles, a planted pickle is never loaded, a forged entry is refused and recomputed, results
read back exactly, and a cache that cannot be used is turned off with one warning."""

import ast
import json
import warnings
from pathlib import Path

import pandas as pd
import pytest

import mutual
from mutual.cache import CacheWarning
from mutual.study import sweep


def _task(t):
    return pd.DataFrame({"t": [t, t + 1], "x": [t / 3, float("nan")], "ok": [True, False], "who": [f"p{t}", None]})


def _sweep(cache, n=4):
    return sweep.run_tasks(_task, range(n), params=lambda t: {"t": t}, cache=cache, scheduler="inline", progress=False)


def test_nothing_in_the_package_unpickles():
    banned = {"pickle", "cPickle", "dill", "cloudpickle", "joblib", "shelve", "marshal"}
    for path in Path(mutual.__file__).parent.rglob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = {a.name.split(".")[0] for a in node.names} | {(getattr(node, "module", "") or "").split(".")[0]}
                assert not names & banned, f"{path} imports {names & banned}"
            if isinstance(node, ast.keyword) and node.arg == "allow_pickle":
                assert isinstance(node.value, ast.Constant) and node.value.value is False, path
            if isinstance(node, ast.Attribute) and node.attr in ("read_pickle", "to_pickle"):
                pytest.fail(f"{path} uses {node.attr}")


def test_a_planted_pickle_is_never_loaded(tmp_path):
    marker = tmp_path / "ran"
    cache = sweep.TaskCache("v", tmp_path / "cache")
    cache.folder.mkdir()
    planted = f"cos\nsystem\n(S'touch {marker}'\ntR.".encode()
    for t in range(4):
        (cache.folder / f"{cache.key({'t': t})}.pkl").write_bytes(planted)
        cache.path({"t": t}).write_bytes(planted)          # the same bytes where a result should be
    with pytest.warns(CacheWarning, match="does not verify"):
        results, stats = _sweep(cache)
    assert not marker.exists() and stats.computed == 4
    assert _sweep(cache)[1].cached == 4                    # healed: the planted files were replaced


FORGED = {  # how a stored result is changed: each must be refused and recomputed
    "a value of another type": lambda d: d["data"][0].__setitem__(0, "1"),
    "an object in a text column": lambda d: d["data"][3].__setitem__(0, {"__class__": "os.system"}),
    "a bool where a number belongs": lambda d: d["data"][1].__setitem__(0, True),
    "another task's key": lambda d: d.__setitem__("key", "0" * 32),
    "an unknown column type": lambda d: d["dtypes"].__setitem__(0, "category"),
    "columns of different lengths": lambda d: d["data"][0].append(3),
    "another format": lambda d: d.__setitem__("format", 99),
    "not an object": lambda d: d.clear(),
}


@pytest.mark.parametrize("forge", FORGED, ids=list(FORGED))
def test_a_forged_entry_is_healed(forge, tmp_path):
    cache = sweep.TaskCache("v", tmp_path)
    truth, _ = _sweep(cache, 1)
    path = cache.path({"t": 0})
    stored = json.loads(path.read_text())
    FORGED[forge](stored)
    path.write_text(json.dumps(stored))
    with pytest.warns(CacheWarning, match="does not verify"):
        again, stats = _sweep(cache, 1)
    assert stats.computed == 1
    pd.testing.assert_frame_equal(again[0], truth[0])
    assert _sweep(cache, 1)[1].cached == 1


def test_results_read_back_exactly(tmp_path):
    cache = sweep.TaskCache("v", tmp_path)
    first, _ = _sweep(cache)
    second, stats = _sweep(cache)
    assert stats.cached == 4
    for a, b in zip(first, second):
        pd.testing.assert_frame_equal(a, b)


def test_a_folder_where_a_result_should_be_heals(tmp_path):
    cache = sweep.TaskCache("v", tmp_path / "cache")
    cache.path({"t": 0}).mkdir(parents=True)
    (cache.path({"t": 0}) / "inside").write_text("x")
    results, stats = _sweep(cache)
    assert stats.computed == 4 and not cache.disabled and cache.path({"t": 0}).is_file()
    assert _sweep(cache)[1].cached == 4


@pytest.mark.parametrize("broken", ["the cache folder is a file", "no home folder"])
def test_a_cache_that_cannot_be_used_is_turned_off_with_one_warning(broken, tmp_path, monkeypatch):
    (tmp_path / "file").write_text("x")
    if broken == "no home folder":
        monkeypatch.delenv("MUTUAL_CACHE_DIR", raising=False)
        monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "file" / "cache"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cache = sweep.TaskCache("v", tmp_path / "file" / "power" if broken.startswith("the cache") else None)
        results, stats = _sweep(cache)
    assert stats.computed == 4 and len(results) == 4 and cache.disabled
    assert len([w for w in caught if issubclass(w.category, CacheWarning)]) == 1
