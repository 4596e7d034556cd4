"""Caches no one else can write (``mutual.cache``): a folder that is not the user's or that others may write is
refused as ssh refuses a key file others can read, with where the cache is and how to clear it; the per-user
key is the user's alone; entries forged without the key -- a recomputed plain checksum, another user's key --
do not verify, and a forged result that verifies is caught by recomputing one cached result."""

import hashlib
import json
import os
import warnings

import numpy as np
import pandas as pd
import pytest

import mutual.cache as cache
from mutual.cache import CacheWarning
from mutual.study import sweep

NOBODY = 65534


@pytest.fixture
def root(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("MUTUAL_CACHE_DIR", str(folder))
    cache._WARNED.clear()
    yield folder
    cache._WARNED.clear()


def _made(path, mode, owner=None):
    path.mkdir(parents=True, exist_ok=True)
    path.chmod(mode)
    if owner is not None:
        os.chown(path, owner, -1)
    return path


@pytest.mark.parametrize("parent_mode, mode, owner, reason", [
    (0o755, 0o700, None, None),
    (0o755, 0o755, None, None),
    (0o1777, 0o700, None, None),                              # a private folder in /tmp: others cannot move it
    (0o755, 0o777, None, "cache can be written by anyone (mode 777)"),
    (0o755, 0o1777, None, "cache can be written by anyone (mode 1777)"),   # sticky: others still add entries
    (0o777, 0o700, None, "shared can be written by anyone (mode 777)"),    # the folder above can be swapped
    (0o755, 0o700, NOBODY, f"cache is owned by user id {NOBODY}, not by you"),
    (0o755, 0o700, "parent", f"shared is owned by user id {NOBODY}"),
])
def test_a_cache_folder_is_trusted_only_when_no_one_else_can_write_it(tmp_path, parent_mode, mode, owner, reason):
    if os.geteuid() != 0 and owner is not None:
        pytest.skip("changing a folder's owner needs root")
    parent = _made(tmp_path / "shared", parent_mode, NOBODY if owner == "parent" else None)
    folder = _made(parent / "cache", mode, owner if owner != "parent" else None)
    found = cache.insecure(folder)
    assert (found is None) if reason is None else (reason in found), found


def test_a_group_writable_folder_is_refused_unless_the_group_is_the_users_own(tmp_path, monkeypatch):
    folder = _made(tmp_path / "cache", 0o770)
    monkeypatch.setattr(cache, "_private_group", lambda st: False)
    assert "can be written by its group" in cache.insecure(folder)
    monkeypatch.setattr(cache, "_private_group", lambda st: True)
    assert cache.insecure(folder) is None


def test_an_untrusted_cache_is_not_used_and_the_warning_says_where_and_how_to_clear_it(root):
    _made(root, 0o777)
    with pytest.warns(CacheWarning, match=f"the cache in {root}/power cannot be used .*can be written by anyone"
                                          f".*chmod -R go-w {root}.*MUTUAL_CACHE_DIR.*rm -rf {root}"):
        assert cache.cache_folder("power") is None


def test_nothing_is_created_inside_a_cache_that_cannot_be_trusted(root):
    _made(root, 0o777)
    with pytest.warns(CacheWarning):
        assert cache.cache_folder("reachability") is None
    assert list(root.iterdir()) == []


@pytest.mark.parametrize("fault, offers_chmod", [("root", True), ("parent", False), ("owner", False)])
def test_chmod_is_offered_only_where_it_helps(tmp_path, monkeypatch, fault, offers_chmod):
    """A cache folder of the user's that others may write: chmod fixes it. A shared folder above it, or a folder
    another user owns: chmod cannot, so only MUTUAL_CACHE_DIR is offered."""
    if fault == "owner" and os.geteuid() != 0:
        pytest.skip("changing a folder's owner needs root")
    parent = _made(tmp_path / "shared", 0o777 if fault == "parent" else 0o755)
    root = _made(parent / "cache", 0o777 if fault == "root" else 0o700, NOBODY if fault == "owner" else None)
    monkeypatch.setenv("MUTUAL_CACHE_DIR", str(root))
    cache._WARNED.clear()
    with pytest.warns(CacheWarning) as seen:
        assert cache.cache_folder("power") is None
    text = str(seen[0].message)
    assert ("chmod -R go-w" in text) == offers_chmod and "MUTUAL_CACHE_DIR" in text, text
    cache._WARNED.clear()


def test_the_key_is_the_users_alone_and_made_once(root):
    key = cache.secret_key()
    path = root / "key"
    assert len(key) == 32 and oct(path.stat().st_mode & 0o777) == "0o600" and cache.secret_key() == key
    assert oct(root.stat().st_mode & 0o777) == "0o700"          # the cache folder made here is private too


@pytest.mark.parametrize("spoil, reason", [
    (lambda p: p.chmod(0o644), "mode 644"),
    (lambda p: p.write_bytes(b"short"), "5 bytes"),
    (lambda p: os.chown(p, NOBODY, -1), f"owner id {NOBODY}"),
])
def test_a_key_file_others_may_read_or_that_is_not_the_users_turns_the_caches_off(root, spoil, reason):
    cache.secret_key()
    spoil(root / "key")
    with pytest.warns(CacheWarning, match=f"key file .* must be 32 bytes readable by you alone .*{reason}"):
        assert cache.secret_key() is None


def _task(t):
    return pd.DataFrame({"t": [t], "twice": [2.0 * t]})


def _sweep(c, n=3, fn=_task):
    return sweep.run_tasks(fn, range(n), params=lambda t: {"t": t}, cache=c, scheduler="inline", progress=False)


def _reseal(path, change, secret):
    stored = json.loads(path.read_text())
    stored.pop("mac")
    change(stored)
    stored["mac"] = cache.sign(secret, json.dumps(stored, sort_keys=True))
    path.write_text(json.dumps(stored))


@pytest.mark.parametrize("secret", [b"another user's key, 32 bytes...", None], ids=["another key", "no key"])
def test_a_power_entry_forged_without_the_key_does_not_verify(root, secret):
    c = sweep.TaskCache("v")
    truth, _ = _sweep(c)
    path = c.path({"t": 1})
    if secret is None:                       # the fields changed, the code left as it was
        stored = json.loads(path.read_text())
        stored["data"][1][0] = 99.0
        path.write_text(json.dumps(stored))
    else:
        _reseal(path, lambda d: d["data"][1].__setitem__(0, 99.0), secret)
    with pytest.warns(CacheWarning, match="does not verify: its authentication code does not match"):
        again, stats = _sweep(c)
    assert stats.computed == 1 and all(a.equals(b) for a, b in zip(again, truth))


def test_a_result_that_verifies_but_differs_from_its_recomputation_empties_the_sweeps_cache(root):
    c = sweep.TaskCache("v")
    truth, _ = _sweep(c)
    _reseal(c.path({"t": 0}), lambda d: d["data"][1].__setitem__(0, 99.0), cache.secret_key())
    with pytest.warns(CacheWarning, match="differs from its recomputation"):
        again, stats = _sweep(c)
    assert stats.computed == 3 and all(a.equals(b) for a, b in zip(again, truth))


def test_a_value_function_forged_with_a_recomputed_plain_checksum_does_not_verify(root):
    from mutual.supervision import value_cache
    from mutual.supervision.reachability import GridSpec, value_library
    grid = GridSpec(5.0, (21, 21, 8))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        library = value_library([2.0], 1.0, grid, progress=False)
    path = next((root / "reachability").iterdir())
    with np.load(path) as f:
        fields = {k: f[k] for k in f.files}
    values = fields["values"] + np.float32(0.5)            # the safe set moved, as a forger would
    digest = hashlib.sha256(str(fields["key"]).encode())   # the checksum anyone could recompute
    for part in (values.tobytes(), np.float64(fields["horizon"]).tobytes(), str(fields["params"]).encode()):
        digest.update(part)
    np.savez(path, **{**fields, "values": values, "checksum": np.str_(digest.hexdigest())})
    with pytest.warns(CacheWarning, match=f"{path} does not verify: checksum mismatch"):
        again = value_library([2.0], 1.0, grid, progress=False)
    assert np.array_equal(again[0].values, library[0].values)
    assert value_cache.CACHE_FORMAT == 4
