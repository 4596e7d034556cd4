"""The value-function cache: it serves a second call and recomputes on any change of its key; it cannot be
turned against its user (a planted or forged file is refused and rebuilt, never executed or trusted for
another member); a damaged file or an interrupted build is healed; and a cache that cannot be used (a
folder where a file should be, a read-only or full disk, an unwritable home) leaves the results unchanged
and warns once."""

import os
import pickle
import shutil
import subprocess
import sys
import warnings

import numpy as np
import pytest

import mutual.cache as cache
import mutual.supervision.reachability as reach
from mutual.supervision import value_cache
from mutual.supervision.reachability import GridSpec, SolverSpec, value_library
from mutual.supervision.value_cache import CacheWarning


RADIUS = 1.0


def test_cache_serves_second_call_and_recomputes_on_any_key_change(cache_folder, monkeypatch):
    spec = GridSpec(8.0, (21, 21, 12))
    calls = []
    real = reach._converge

    def counting(w_maxes, *args):
        calls.append(list(w_maxes))
        yield from real(w_maxes, *args)

    monkeypatch.setattr(reach, "_converge", counting)
    first = value_library([1.0, 2.0], RADIUS, spec, progress=False)
    second = value_library([1.0, 2.0], RADIUS, spec, progress=False)
    assert calls == [[1.0, 2.0]]
    assert np.array_equal(first[0].values, second[0].values)
    value_library([1.0, 3.0], RADIUS, spec, progress=False)
    assert calls[-1] == [3.0]
    changes = [dict(obstacle_radius=1.2), dict(grid_spec=GridSpec(8.0, (21, 21, 14))),
               dict(grid_spec=GridSpec(8.5, (21, 21, 12))), dict(solver=SolverSpec(accuracy="medium")),
               dict(solver=SolverSpec(tolerance=3e-3)), dict(speed=2.5), dict(d_max=0.2)]
    for change in changes:
        before = len(calls)
        value_library(**({"w_maxes": [1.0], "obstacle_radius": RADIUS, "grid_spec": spec, "progress": False}
                         | change))
        assert len(calls) == before + 1, change
    monkeypatch.setattr(reach, "_versions", lambda: {"jax": "0.0"})
    value_library([1.0], RADIUS, spec, progress=False)
    assert calls[-1] == [1.0] and len(calls) == 1 + 1 + len(changes) + 1


SMALL = GridSpec(8.0, (21, 21, 12))


@pytest.fixture
def cache_folder(tmp_path, monkeypatch):
    monkeypatch.setenv("MUTUAL_CACHE_DIR", str(tmp_path))
    return tmp_path


def _reseal_npz(path, fields):
    """Write ``fields`` to ``path`` with a checksum consistent with them (as a forger would)."""
    fields = dict(fields)
    fields["checksum"] = np.str_(value_cache._checksum(str(fields["key"]), fields["values"], float(fields["horizon"]),
                                                       str(fields["params"])))
    np.savez(path, **fields)


def _damage(path, how, other=None):
    data = path.read_bytes()
    if how == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif how == "garbage":
        path.write_bytes(np.random.default_rng(0).bytes(len(data)))
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "bit-flip":  # a valid zip whose values no longer match the checksum
        with np.load(path) as f:
            fields = {k: f[k] for k in f.files}
        fields["values"] = fields["values"].copy()
        fields["values"].flat[123] += 0.5
        np.savez(path, **fields)
    elif how == "foreign":  # a valid file of another member copied over this one
        path.write_bytes(other.read_bytes())
    elif how == "nan":  # NaN values with a checksum that matches them (a solver gone wrong)
        with np.load(path) as f:
            fields = {k: f[k] for k in f.files}
        fields["values"] = fields["values"].copy()
        fields["values"].flat[7] = np.nan
        _reseal_npz(path, fields)
    elif how == "old-format":
        with np.load(path) as f:
            np.savez(path, values=f["values"], horizon=f["horizon"])
    else:
        raise AssertionError(how)


@pytest.mark.parametrize("how", ["truncated", "garbage", "empty", "bit-flip", "foreign", "nan", "old-format"])
def test_a_damaged_cache_file_warns_with_its_path_and_is_rebuilt(cache_folder, how):
    fresh = value_library([1.0, 2.0], RADIUS, SMALL, progress=False)
    key = reach.cache_key(1.0, RADIUS, reach.SPEED, 0.0, SMALL, SolverSpec())
    path = value_cache.cache_file(key)
    other = value_cache.cache_file(reach.cache_key(2.0, RADIUS, reach.SPEED, 0.0, SMALL, SolverSpec()))
    assert path.exists() and other.exists()
    _damage(path, how, other)
    with pytest.warns(CacheWarning, match=str(path)):
        again = value_library([1.0, 2.0], RADIUS, SMALL, progress=False)
    assert np.array_equal(again[0].values, fresh[0].values)
    assert np.array_equal(again[1].values, fresh[1].values)
    # the file was rewritten and verifies: a third call is silent
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        third = value_library([1.0], RADIUS, SMALL, progress=False)
    assert np.array_equal(third[0].values, fresh[0].values)


def test_an_interrupted_build_keeps_its_finished_members(cache_folder, monkeypatch):
    real = reach._converge
    computed = []

    def interrupted(w_maxes, *args):
        for item in real(w_maxes, *args):
            computed.append(item[0])
            yield item
            if len(computed) == 1:
                raise KeyboardInterrupt

    monkeypatch.setattr(reach, "_converge", interrupted)
    with pytest.raises(KeyboardInterrupt):
        value_library([1.0, 2.0, 3.0], RADIUS, SMALL, progress=False)
    saved = sorted(cache_folder.glob("reachability/*.npz"))
    assert len(saved) == 1
    assert saved[0] == value_cache.cache_file(reach.cache_key(1.0, RADIUS, reach.SPEED, 0.0, SMALL, SolverSpec()))
    assert not list(cache_folder.glob("reachability/.*"))  # no temporary files left behind
    monkeypatch.setattr(reach, "_converge", real)
    calls = []

    def counting(w_maxes, *args):
        calls.append(list(w_maxes))
        yield from real(w_maxes, *args)

    monkeypatch.setattr(reach, "_converge", counting)
    value_library([1.0, 2.0, 3.0], RADIUS, SMALL, progress=False)
    assert calls == [[2.0, 3.0]]


# cells of 0.25 m: the head-on reach of w_max = 1 (sqrt 7 = 2.65 m) and of w_max = 2 (2 m) lie 2.6 cells apart
GRID = GridSpec(5.0, (41, 41, 12))


@pytest.fixture
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("MUTUAL_CACHE_DIR", str(tmp_path / "cache"))
    cache._WARNED.clear()
    yield tmp_path / "cache"
    cache._WARNED.clear()


@pytest.fixture(scope="module")
def fresh(tmp_path_factory):
    """The two members computed once, with their cache files (copied into each test's cache)."""
    folder = tmp_path_factory.mktemp("value-cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MUTUAL_CACHE_DIR", str(folder))
        library = value_library([1.0, 2.0], RADIUS, GRID, progress=False)
    return library, folder


def _path(w):
    return value_cache.cache_file(reach.cache_key(w, RADIUS, reach.SPEED, 0.0, GRID, SolverSpec()))


def _fields(path):
    with np.load(path) as f:
        return {k: f[k] for k in f.files}


def _reseal(path, fields):
    """Write ``fields`` with a checksum consistent with them, as someone forging the file would."""
    fields = dict(fields)
    fields["checksum"] = np.str_(value_cache._checksum(str(fields["key"]), np.asarray(fields["values"]),
                                                       float(fields["horizon"]), str(fields["params"])))
    np.savez(path, **fields)


class Planted:
    """Unpickling this creates the file named ``marker``: the proof that loading ran code."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (open, (self.marker, "w"))


def _forge(path, other, how, marker):
    mine, theirs = _fields(path), _fields(other)
    if how == "another member's values, resealed":
        _reseal(path, {**mine, "values": theirs["values"], "horizon": theirs["horizon"]})
    elif how == "another member's file, key rewritten":
        _reseal(path, {**theirs, "key": mine["key"]})
    elif how == "other parameters, resealed":
        params = str(mine["params"]).replace('"radius": 1.0', '"radius": 1.5')
        assert params != str(mine["params"])
        _reseal(path, {**mine, "params": np.str_(params)})
    elif how == "a pickle":
        path.write_bytes(pickle.dumps(Planted(str(marker))))
    elif how == "an object array in the archive":
        np.savez(path, **{**mine, "values": np.array([Planted(str(marker))], dtype=object)})
    elif how == "float64 values":
        _reseal(path, {**mine, "values": mine["values"].astype(np.float64)})
    elif how == "a text horizon":
        _reseal(path, {**mine, "horizon": np.str_("inf")})
    elif how == "an extra field":
        _reseal(path, {**mine, "extra": np.zeros(3)})
    elif how == "a bare array":
        np.save(open(path, "wb"), mine["values"])
    elif how == "no parameters (the old format)":
        np.savez(path, **{k: v for k, v in mine.items() if k != "params"})
    elif how == "parameters that are not JSON":
        _reseal(path, {**mine, "params": np.str_("{not json")})
    else:
        raise AssertionError(how)


FORGERIES = [  # (how the w_max = 1 file is forged, what the warning says)
    ("another member's values, resealed", "another member's values"),
    ("another member's file, key rewritten", "other parameters"),
    ("other parameters, resealed", "other parameters .radius"),
    ("a pickle", "unreadable"),
    ("an object array in the archive", "unreadable"),
    ("float64 values", "dtype float64"),
    ("a text horizon", "field 'horizon'"),
    ("an extra field", "not a cache file of this format"),
    ("a bare array", "bare array"),
    ("no parameters (the old format)", "not a cache file of this format"),
    ("parameters that are not JSON", "not JSON"),
]


@pytest.mark.parametrize("how, reason", FORGERIES, ids=[f[0] for f in FORGERIES])
def test_a_forged_or_planted_file_is_refused_and_rebuilt(fresh, private_cache, tmp_path, how, reason):
    library, folder = fresh
    shutil.copytree(folder / "reachability", private_cache / "reachability")
    marker = tmp_path / "code-ran"
    _forge(_path(1.0), _path(2.0), how, marker)
    with pytest.warns(CacheWarning, match=f"{_path(1.0)} does not verify: .*{reason}"):
        again = value_library([1.0, 2.0], RADIUS, GRID, progress=False)
    assert not marker.exists(), "loading the cache ran code planted in it"
    assert np.array_equal(again[0].values, library[0].values) and np.array_equal(again[1].values, library[1].values)
    with warnings.catch_warnings():          # healed: the next run is silent
        warnings.simplefilter("error")
        value_library([1.0], RADIUS, GRID, progress=False)


def test_the_forged_file_no_longer_changes_a_fit(fresh, private_cache):
    """The review's case: w_max = 2's values under w_max = 1 moved a fit of a w_max = 2 supervisor to 1."""
    from mutual.supervision.fit import fit_supervisor
    from mutual.supervision.supervisor import NoisySupervisor, collect_interventions
    library, folder = fresh
    shutil.copytree(folder / "reachability", private_cache / "reachability")
    states = collect_interventions(NoisySupervisor(library[1], 0.3, 0.05), 60, np.random.default_rng(0), 4.5)
    assert fit_supervisor(library, states).w_max == 2.0
    _forge(_path(1.0), _path(2.0), "another member's values, resealed", None)
    with pytest.warns(CacheWarning, match="another member's values"):
        reloaded = value_library([1.0, 2.0], RADIUS, GRID, progress=False)
    assert fit_supervisor(reloaded, states).w_max == 2.0


def test_the_key_covers_the_solver_code(monkeypatch):
    """An edit to the dynamics, the grid or the solver loop changes every key (no manual version to bump)."""
    key = reach.cache_key(1.0, RADIUS, reach.SPEED, 0.0, GRID, SolverSpec())
    assert reach._versions()["solver_code"] == reach.solver_code_version()
    real = reach.inspect.getsource
    monkeypatch.setattr(reach.inspect, "getsource", lambda obj: real(obj).replace("jnp.cos", "jnp.sin"))
    reach.solver_code_version.cache_clear()
    try:
        edited = reach.cache_key(1.0, RADIUS, reach.SPEED, 0.0, GRID, SolverSpec())
    finally:
        monkeypatch.undo()
        reach.solver_code_version.cache_clear()
    assert edited != key == reach.cache_key(1.0, RADIUS, reach.SPEED, 0.0, GRID, SolverSpec())


@pytest.mark.parametrize("kind", ["an empty folder", "a folder with files", "a link"])
def test_a_folder_where_a_cache_file_should_be_heals(fresh, private_cache, tmp_path, kind):
    library, _ = fresh
    path = _path(1.0)
    path.parent.mkdir(parents=True)
    if kind == "a link":
        path.symlink_to(tmp_path / "elsewhere")
    else:
        path.mkdir()
        if kind == "a folder with files":
            (path / "inside").write_text("x")
    with pytest.warns(CacheWarning, match="was a folder or a link"):
        again = value_library([1.0], RADIUS, GRID, progress=False)
    assert np.array_equal(again[0].values, library[0].values)
    assert path.is_file() and not path.is_symlink()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        value_library([1.0], RADIUS, GRID, progress=False)


def _only_cache_warnings(record):
    return [str(w.message) for w in record if issubclass(w.category, CacheWarning)]


@pytest.mark.parametrize("setting", ["MUTUAL_CACHE_DIR is a file", "its reachability folder is a file",
                                     "HOME is a file", "no home folder"])
def test_an_unusable_cache_folder_runs_without_the_cache_and_warns_once(fresh, tmp_path, monkeypatch, setting):
    library, _ = fresh
    cache._WARNED.clear()
    blocker = tmp_path / "blocker"
    blocker.write_text("a file")
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    if setting == "MUTUAL_CACHE_DIR is a file":
        monkeypatch.setenv("MUTUAL_CACHE_DIR", str(blocker))
    elif setting == "its reachability folder is a file":
        (tmp_path / "cache").mkdir()
        (tmp_path / "cache" / "reachability").write_text("a file")
        monkeypatch.setenv("MUTUAL_CACHE_DIR", str(tmp_path / "cache"))
    else:
        monkeypatch.delenv("MUTUAL_CACHE_DIR")
        monkeypatch.setenv("HOME", str(blocker))
        if setting == "no home folder":
            monkeypatch.delenv("HOME")
            monkeypatch.setattr(cache.Path, "home", classmethod(lambda cls: (_ for _ in ()).throw(RuntimeError("no home"))))
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        again = value_library([1.0, 2.0], RADIUS, GRID, progress=False)
        value_library([1.0, 2.0], RADIUS, GRID, progress=False)
    messages = _only_cache_warnings(record)
    assert len(messages) == 1 and "running without it" in messages[0], messages
    assert np.array_equal(again[0].values, library[0].values)


MOUNTED = """
import warnings
import numpy as np
import mutual.cache
from mutual.supervision.reachability import GridSpec, value_library
warnings.simplefilter("always")
with warnings.catch_warnings(record=True) as record:
    lib = value_library([1.0, 2.0, 3.0], 1.0, GridSpec(5.0, (41, 41, 12)), progress=False)
cache = [str(w.message) for w in record if issubclass(w.category, mutual.cache.CacheWarning)]
print(len(cache), repr(cache[0] if cache else ""), float(lib[0].values.sum()))
"""


def _in_a_mount(tmp_path, options, prepare=""):
    """Run MOUNTED with MUTUAL_CACHE_DIR on a tmpfs mounted with ``options`` in a private mount namespace."""
    if shutil.which("unshare") is None:
        pytest.skip("needs unshare(1)")
    folder = tmp_path / "mnt"
    folder.mkdir()
    script = (f"mount -t tmpfs -o {options} tmpfs {folder} && {prepare} "
              f"exec {sys.executable} -c {_quote(MOUNTED)}")
    env = {**os.environ, "MUTUAL_CACHE_DIR": str(folder / "cache"), "JAX_COMPILATION_CACHE_DIR": str(tmp_path / "jax")}
    out = subprocess.run(["unshare", "-m", "--propagation", "private", "sh", "-c", script], capture_output=True,
                         text=True, env=env, timeout=600)
    if "mount:" in out.stderr or "unshare:" in out.stderr:
        pytest.skip(f"mounting a tmpfs is not allowed here: {out.stderr.strip()[:200]}")
    return out


def _quote(text):
    return "'" + text.replace("'", "'\\''") + "'"


@pytest.mark.parametrize("disk, options, prepare", [
    ("read-only", "ro,size=64k", ""),
    ("full", "size=16k", ""),          # one member's file is 80 kB
    ("read-only after the folder was made", "size=64k",
     "mkdir -p {mnt}/cache/reachability && mount -o remount,ro {mnt} &&"),
])
def test_a_read_only_or_full_disk_runs_without_the_cache_and_warns_once(fresh, tmp_path, disk, options, prepare):
    library, _ = fresh
    out = _in_a_mount(tmp_path, options, prepare.format(mnt=tmp_path / "mnt"))
    assert out.returncode == 0, out.stderr[-2000:]
    count, message, total = out.stdout.split(" ", 1)[0], *out.stdout.rsplit(" ", 1)
    assert count == "1" and "running without it" in message, out.stdout
    assert float(total) == float(library[0].values.sum())
    assert "Traceback" not in out.stderr


def test_no_cache_in_the_package_uses_pickle():
    """No module loads a pickle (the power sweep's cache is JSON, the value functions npz without pickles)."""
    root = os.path.dirname(cache.__file__)
    for folder, _, files in os.walk(root):
        for name in files:
            text = open(os.path.join(folder, name)).read() if name.endswith(".py") else ""
            assert "pickle.load" not in text and "allow_pickle=True" not in text, f"{name} loads pickles"
