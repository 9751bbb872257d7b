"""Compiled libraries kept on disk between processes: where, under which name, how written.

* **Where.** `CompileOptions.cache_dir <ekf.compiled.CompileOptions>` if given, else
  ``$RAILNAV_CACHE_DIR/ekf``, else ``<user cache directory>/railnav/ekf``: the platform's
  convention, as ``platformdirs.user_cache_dir`` has it (``$XDG_CACHE_HOME`` or
  ``~/.cache`` on Linux, ``~/Library/Caches`` on macOS, ``%LOCALAPPDATA%`` on Windows).
  The variable is the distribution's (``railnav``), the subfolder this package's.
* **Name.** ``ekf_<key>.so``; the caller's key is a hash of what is compiled and how
  (`ekf.compiled`: the CasADi function's serialization, the C template, the compiler
  command, the CasADi version), so a hit needs neither code generation nor a compiler.
* **Writes.** A library is compiled into a temporary directory inside the cache directory
  and moved into place with ``os.replace``: a reader never sees half a library.
* **Concurrent processes** (Monte Carlo workers starting together): a lock file per key
  (``fcntl.flock``, where the platform has it) lets one process compile while the others
  wait and then load its library; without ``fcntl`` they may compile the same library
  twice, and the last ``os.replace`` wins (the files are identical).
* **Not writable** (a read-only home, a full disk): a library already in the directory is
  still loaded; a missing one is compiled into a private temporary directory, loaded and
  deleted, with one warning per directory naming ``RAILNAV_CACHE_DIR``. Runs stay
  correct and fast; only the next process compiles again.
"""
from __future__ import annotations

import ctypes
import functools
import logging
import os
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

try:
    import fcntl
except ImportError:                     # pragma: no cover - Windows
    fcntl = None

__all__ = ["CACHE_ENV", "user_cache_dir", "cache_root", "default_cache_dir", "load_library"]

log = logging.getLogger(__name__)

#: Environment variable naming the cache root of the distribution (libraries go in ``ekf/``).
CACHE_ENV = "RAILNAV_CACHE_DIR"
#: Subfolder of the cache root that holds this package's libraries.
SUBFOLDER = "ekf"
#: Name of the distribution, the folder in the user cache directory.
APP_NAME = "railnav"

#: ``build(path)`` writes a shared library at ``path`` (raises on failure).
Builder = Callable[[Path], None]


def user_cache_dir() -> Path:
    """The user's cache directory for this distribution (``platformdirs`` convention).

    Falls back to ``<tmp>/railnav-cache-<user>`` when the home directory is unknown.
    """
    try:
        if sys.platform == "win32":     # pragma: no cover - not tested on Linux CI
            base = Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
            return base / APP_NAME / "Cache"
        if sys.platform == "darwin":    # pragma: no cover
            return Path.home() / "Library" / "Caches" / APP_NAME
        xdg = os.environ.get("XDG_CACHE_HOME")
        base = Path(xdg) if xdg and os.path.isabs(xdg) else Path.home() / ".cache"
        return base / APP_NAME
    except RuntimeError:                # Path.home(): no HOME and no passwd entry
        user = os.environ.get("USER") or str(getattr(os, "getuid", lambda: "user")())
        return Path(tempfile.gettempdir()) / f"{APP_NAME}-cache-{user}"


def cache_root() -> Path:
    """``$RAILNAV_CACHE_DIR`` if the variable is set, else `user_cache_dir` (the root of
    every on-disk cache of the distribution; this package's libraries are in ``ekf/``)."""
    root = os.environ.get(CACHE_ENV)
    return Path(root) if root else user_cache_dir()


def default_cache_dir() -> Path:
    """``$RAILNAV_CACHE_DIR/ekf`` if the variable is set, else `user_cache_dir` ``/ekf``."""
    return cache_root() / SUBFOLDER


def load_library(directory: Path, key: str, build: Builder) -> tuple[ctypes.CDLL, float]:
    """The library ``ekf_<key>.so`` from the cache directory, built there if missing.

    Parameters
    ----------
    directory : Path
        The cache directory (created if missing).
    key : str
        File-name-safe hash of what the library is (module docstring).
    build : callable
        ``build(path)`` compiles the library to ``path``; called only on a cache miss.

    Returns
    -------
    library : ctypes.CDLL
    seconds : float
        Wall time this process spent building (0 on a hit, or when another process
        built it while this one waited).
    """
    target = directory / f"ekf_{key}.so"
    if target.is_file():
        return ctypes.CDLL(str(target)), 0.0
    try:
        directory.mkdir(parents=True, exist_ok=True)
        lock = open(directory / f"ekf_{key}.lock", "a")     # noqa: SIM115 (closed below)
    except OSError as exc:
        _warn_not_writable(str(directory), f"{type(exc).__name__}: {exc}")
        return _load_private(build)
    with lock, _exclusive(lock):
        if target.is_file():                                # built while we waited
            return ctypes.CDLL(str(target)), 0.0
        start = time.perf_counter()
        try:
            with tempfile.TemporaryDirectory(dir=directory) as tmp:
                partial = Path(tmp) / target.name
                build(partial)
                os.replace(partial, target)
        except OSError as exc:                              # e.g. the disk filled up
            _warn_not_writable(str(directory), f"{type(exc).__name__}: {exc}")
            return _load_private(build)
        seconds = time.perf_counter() - start
    log.info("compiled %s in %.2f s", target, seconds)
    return ctypes.CDLL(str(target)), seconds


def _load_private(build: Builder) -> tuple[ctypes.CDLL, float]:
    """Build into a private temporary directory, load, delete (the mapping stays)."""
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="ekf-", ignore_cleanup_errors=True) as tmp:
        path = Path(tmp) / "library.so"
        build(path)
        library = ctypes.CDLL(str(path))
    return library, time.perf_counter() - start


@contextmanager
def _exclusive(lock_file) -> Iterator[None]:
    """Hold an exclusive advisory lock on an open file (no-op without ``fcntl``)."""
    if fcntl is None:                   # pragma: no cover - Windows
        yield
        return
    fcntl.flock(lock_file.fileno(), fcntl.LOCK_EX)
    try:
        yield
    finally:
        fcntl.flock(lock_file.fileno(), fcntl.LOCK_UN)


@functools.lru_cache(maxsize=None)
def _warn_not_writable(directory: str, reason: str) -> None:
    """One warning per directory (and reason) and process."""
    log.warning("cache directory %s is not writable (%s): compiled code is not kept for "
                "later runs; set %s to a writable directory", directory, reason, CACHE_ENV)
