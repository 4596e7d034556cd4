"""Where expensive results are cached: ``$MUTUAL_CACHE_DIR``, else the user's cache folder
(``$XDG_CACHE_HOME/mutual``, by default ``~/.cache/mutual``). The compendium's Makefile points
it at the repository's ``.cache/`` so that ``make clean`` removes it.

Every disk cache of the package goes through the helpers here, so that a cache never stops a
run: a cache folder that cannot be created or written (a read-only disk or folder, an unwritable
or missing home folder, a full disk, a file where a folder should be) and an entry that cannot be
read or replaced (a folder where a file should be) leave the run going without the cache, with
one :class:`CacheWarning` per folder saying where and why. A folder found where an entry should
be is removed, so the cache heals. Entries hold data only (``.npz`` read with
``allow_pickle=False``, JSON), never anything that runs code when it is loaded.

No one else may write the cache. As ssh refuses a key file that others can read, a cache folder that is
not owned by this user (or root), or that its group or others may write -- or a folder above it that
others may write and that is not sticky like ``/tmp`` -- is not used (:func:`insecure`; one warning that
says where the cache is, why, and how to fix or clear it). Entries are authenticated: each carries an
HMAC-SHA256 (:func:`sign`) under a per-user secret key, 32 random bytes in ``<cache folder>/key``, made on
first use, readable by this user alone (a key file that others may read, or that another user owns, turns
the caches off), so an entry forged by anyone without the key -- with a recomputed checksum, or copied
from another user's cache -- does not verify and is recomputed. Clearing the cache (``rm -rf`` of the
folder; ``make clean``) is always safe: everything in it is recomputed.
"""

import hashlib
import hmac
import os
import shutil
import stat
import warnings
from pathlib import Path

from .atomic import atomic_path

_WARNED = set()   # folders whose cache was reported unusable in this process (one warning each)


class CacheWarning(RuntimeWarning):
    """A cache entry did not verify and is being rebuilt, or a cache cannot be used and the run goes
    on without it."""


def cache_dir() -> Path:
    """The cache folder (not created here; writers create what they need through :func:`cache_folder`).
    Raises OSError when there is no ``$MUTUAL_CACHE_DIR`` and no home folder to put it in."""
    if os.environ.get("MUTUAL_CACHE_DIR"):
        return Path(os.environ["MUTUAL_CACHE_DIR"])
    if os.environ.get("XDG_CACHE_HOME"):
        return Path(os.environ["XDG_CACHE_HOME"]) / "mutual"
    try:
        return Path.home() / ".cache" / "mutual"
    except (RuntimeError, KeyError):
        raise FileNotFoundError("no home folder to put the cache in (set MUTUAL_CACHE_DIR)") from None


def unusable(where, err, doing="running without it", stacklevel=3):
    """Say once per ``where`` (a cache folder) that its cache cannot be used, and why (the warning points
    ``stacklevel`` frames up, as :func:`warnings.warn` counts them from here)."""
    where = str(where)
    if where in _WARNED:
        return
    _WARNED.add(where)
    reason = f"{type(err).__name__}: {err}" if isinstance(err, BaseException) else str(err)
    warnings.warn(f"the cache in {where} cannot be used ({reason}); {doing}", CacheWarning, stacklevel=stacklevel)


def cache_folder(name, writable=True):
    """``cache_dir() / name``, created if needed, or None (one :class:`CacheWarning`) when it cannot
    be created or, with ``writable``, written (a read-only disk or folder, no home folder), or when others
    may write it (:func:`insecure`)."""
    try:
        folder = cache_dir() / name
    except OSError as err:
        unusable("the cache folder", err)
        return None
    return usable_folder(folder, writable)


def usable_folder(folder, writable=True):
    """``folder`` created if needed (readable by this user only when new), or None with one :class:`CacheWarning`
    when it cannot be created, written (with ``writable``) or trusted (:func:`insecure`)."""
    folder = Path(folder)
    reason = insecure(folder)                 # nothing is created inside a folder that cannot be trusted
    if not reason:
        try:
            _private_mkdir(folder)
            if writable and not os.access(folder, os.W_OK | os.X_OK):
                raise PermissionError(f"{folder} is not writable")
        except OSError as err:
            unusable(folder, err)
            return None
        reason = insecure(folder)
    if reason:
        unusable(folder, reason, doing=advice(folder))
        return None
    return folder


def _private_mkdir(folder):
    """Create ``folder`` and its missing parents; the folders made here are this user's alone (0700)."""
    missing = [p for p in [folder, *folder.parents] if not p.exists()]
    folder.mkdir(parents=True, exist_ok=True)
    for made in missing:
        try:
            os.chmod(made, 0o700)
        except OSError:
            pass


def advice(folder):
    """What to do about a cache that cannot be trusted: where it is, how to fix or clear it. ``chmod`` is offered
    only where it helps: every folder at fault is this user's and inside the cache."""
    try:
        root = cache_dir()
    except OSError:
        root = Path(folder)
    at = _untrusted(folder)
    inside = at is None or (os.stat(at[0]).st_uid == os.geteuid() and at[0].is_relative_to(os.path.realpath(root)))
    fix = f"make it yours alone (chmod -R go-w {root}), or " if inside else ""
    return f"running without it; {fix}set MUTUAL_CACHE_DIR to a folder of your own; clearing it is safe: rm -rf {root}"


def _private_group(st):
    """Whether ``st``'s group is this user's own (a user private group with no other member)."""
    try:
        import grp
        import pwd
        user, group = pwd.getpwuid(os.geteuid()).pw_name, grp.getgrgid(st.st_gid)
    except (ImportError, KeyError):
        return False
    return group.gr_name == user and set(group.gr_mem) <= {user}


def insecure(folder):
    """Why ``folder`` cannot be trusted as a cache, or None. It and every folder above it must be owned by this
    user or root; the folder must be writable by no one else (its group only when that is this user's private
    group), and a folder above it likewise unless it is sticky (``/tmp``: others cannot move our folder away)."""
    found = _untrusted(folder)
    return found[1] if found else None


def _untrusted(folder):
    """``(path, reason)`` of the first folder at or above ``folder`` (resolved) that :func:`insecure` faults,
    or None."""
    me = os.geteuid()
    path = Path(os.path.realpath(folder))
    for at in [path, *path.parents]:
        try:
            st = os.stat(at)
        except OSError:
            continue                                  # not made yet: checked when it is
        if st.st_uid not in (me, 0):
            return at, f"{at} is owned by user id {st.st_uid}, not by you: its owner could change what the cache holds"
        others = st.st_mode & 0o002 or (st.st_mode & 0o020 and not _private_group(st))
        if others and not (at != path and st.st_mode & stat.S_ISVTX):
            who = "anyone" if st.st_mode & 0o002 else "its group"
            return at, (f"{at} can be written by {who} (mode {stat.S_IMODE(st.st_mode):o}): whoever can write there "
                        "could change what the cache holds")
    return None


KEY_BYTES = 32


def secret_key(root=None):
    """This user's secret key for authenticating cache entries (``<root>/key``, by default in :func:`cache_dir`;
    module docstring), made on first use; None (one :class:`CacheWarning`) when the cache folder cannot be used or
    the key file is not this user's alone."""
    if root is None:
        try:
            root = cache_dir()
        except OSError as err:
            unusable("the cache folder", err)
            return None
    if usable_folder(root) is None:
        return None
    path = root / "key"
    if not path.exists() and not path.is_symlink():
        _make_key(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    except OSError as err:
        unusable(root, f"its key file {path} cannot be read ({err.strerror or err})", advice(root))
        return None
    with os.fdopen(fd, "rb") as handle:
        st = os.fstat(handle.fileno())
        key = handle.read(KEY_BYTES + 1)
    if st.st_uid != os.geteuid() or st.st_mode & 0o077 or len(key) != KEY_BYTES:
        unusable(root, f"its key file {path} must be {KEY_BYTES} bytes readable by you alone (mode 600, owned by "
                       f"you; it is mode {stat.S_IMODE(st.st_mode):o}, owner id {st.st_uid}, {len(key)} bytes)",
                 advice(root))
        return None
    return key


def _make_key(path):
    """Write a new random key to ``path`` (mode 600), atomically: a key made meanwhile by another process wins."""
    tmp = path.with_name(f".key.{os.getpid()}")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
        with os.fdopen(fd, "wb") as handle:
            handle.write(os.urandom(KEY_BYTES))
        os.link(tmp, path)
    except FileExistsError:
        pass
    except OSError:
        pass                                          # reported when the key is read
    finally:
        try:
            os.unlink(tmp)
        except OSError:
            pass


def sign(key, *parts):
    """HMAC-SHA256 (hex) of ``parts`` (bytes or text, each length-prefixed) under ``key``."""
    mac = hmac.new(key, digestmod=hashlib.sha256)
    for part in parts:
        data = part.encode() if isinstance(part, str) else bytes(part)
        mac.update(len(data).to_bytes(8, "big") + data)
    return mac.hexdigest()


def clear_entry(path):
    """Make room for the cache entry ``path``: remove a folder (or link) found where the file should be.
    Returns False (one :class:`CacheWarning`) when that cannot be done."""
    path = Path(path)
    try:
        if path.is_symlink():
            path.unlink()
        elif path.is_dir():
            shutil.rmtree(path)
    except OSError as err:
        unusable(path.parent, err)
        return False
    return True


def write_entry(path, write):
    """Atomically write the cache entry ``path`` with ``write(temporary_path)``; return ``path``, or None
    (one :class:`CacheWarning` per folder) when the disk refuses (read-only, full, no permission)."""
    path = Path(path)
    try:
        if not clear_entry(path):
            return None
        with atomic_path(path) as tmp:
            write(tmp)
    except OSError as err:
        unusable(path.parent, err)
        return None
    return path
