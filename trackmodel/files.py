"""Atomic file output, shared by every package that writes files.

Nothing the project writes is ever left half-written: data goes to a temporary file in
the target directory, which replaces the target only when writing succeeded
(``os.replace`` is atomic on POSIX and Windows for paths on one file system). A command's
whole output directory is written the same way (`output_directory`): into a hidden
sibling that is renamed into place when complete, so ``--out`` is either complete or
absent, and an existing one is replaced whole or not at all.
"""
from __future__ import annotations

import contextlib
import glob
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import IO

from trackmodel.errors import InputError

__all__ = ["atomic_write", "atomic_write_text", "atomic_write_csv", "output_directory",
           "check_output_file", "directory_lock", "LOCK_FILE"]


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "w", *,
                 encoding: str | None = "utf-8", newline: str | None = None) -> Iterator[IO]:
    """Open a temporary file that replaces `path` when the block exits without error.

    Parameters
    ----------
    path : str or os.PathLike
        Final file name. Its directory must exist.
    mode : {"w", "wb"}
        Text or binary.
    encoding, newline
        As for `open`, text mode only.

    Yields
    ------
    file object
        Write to it; on an exception the temporary file is removed and `path` is untouched.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb', got {mode!r}")
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix="-" + os.path.basename(path), dir=directory)
    try:
        kwargs = {} if mode == "wb" else {"encoding": encoding, "newline": newline}
        with os.fdopen(fd, mode, **kwargs) as fh:
            yield fh
        os.chmod(tmp, _default_file_mode())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def _default_file_mode() -> int:
    """The permissions `open` would give a new file (0o666 minus the umask)."""
    return 0o666 & ~_umask()


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write `text` to `path` atomically (UTF-8)."""
    with atomic_write(path) as fh:
        fh.write(text)


def atomic_write_csv(path: str | os.PathLike, frame, *, float_format: str | None = None,
                     decimals: Mapping[str, int] | None = None) -> None:
    """Write a pandas table to `path` atomically as CSV, no index, by pyarrow's fast
    writer (`trackmodel.csv_table.write_csv`: ``float_format="%.Ng"`` keeps N significant
    digits, None the shortest round-trip form; `decimals` rounds the named columns to so
    many decimals)."""
    from trackmodel.csv_table import write_csv  # pyarrow: only when a table is written

    with atomic_write(path, "wb") as fh:
        write_csv(fh, frame, float_format=float_format, decimals=decimals)


#: Name parts of an output directory's hidden siblings: the one being written, and the
#: previous one while it is being replaced (``.<name>.tmp-<pid>-<random>``).
_TMP_TAG = ".tmp-"
_OLD_TAG = ".old-"


@contextlib.contextmanager
def output_directory(path: str | os.PathLike, *, overwrite: bool = False,
                     inputs: Iterable[str | os.PathLike] = ()) -> Iterator[Path]:
    """A directory of outputs written whole or not at all.

    On entry, before any work, the destination is checked and a hidden sibling directory
    ``.<name>.tmp-<pid>-<random>`` is created (which proves the parent writable); the
    block writes into it; on a clean exit it is renamed to `path` (``os.rename``: atomic
    on one file system), replacing an existing `path` whole; on any exception
    (``KeyboardInterrupt`` included) it is removed and `path` is untouched. A killed
    process leaves at most the hidden sibling, which the next call on `path` removes
    when its process is gone.

    Parameters
    ----------
    path : str or os.PathLike
        The output directory (its parents are created).
    overwrite : bool
        Replace an existing non-empty `path` (all its files go: no stale file survives).
    inputs : iterable of path
        Files the work reads: refused inside a `path` that `overwrite` would remove.

    Yields
    ------
    pathlib.Path
        The directory to write into.

    Raises
    ------
    InputError
        Naming `path`: it is a file, the working directory or one of its parents, not
        empty (without `overwrite`), holds an input (with it), or cannot be written.
    """
    final = Path(path)
    parent = final.absolute().parent
    if parent.is_dir():
        _remove_stale(parent, final.name)
    _check_destination(final, overwrite, inputs)
    tmp = None
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}{_TMP_TAG}{os.getpid()}-",
                                    dir=parent))
        os.chmod(tmp, 0o777 & ~_umask())
    except BaseException as exc:        # Ctrl-C included: the sibling made goes too
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
        if not isinstance(exc, OSError):
            raise
        raise InputError(f"cannot write here: {exc.strerror or exc}", path=final) from None
    try:
        yield tmp
        _commit(tmp, final, overwrite)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        name = os.fspath(exc.filename or "")
        if not name.startswith(os.fspath(tmp)):
            raise                       # e.g. an input that cannot be read: its own message
        raise InputError(f"cannot write: {exc.strerror or exc} (nothing was written)",
                         path=final / os.path.relpath(name, tmp)) from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


def _check_destination(final: Path, overwrite: bool, inputs) -> None:
    if final.exists() and not final.is_dir():
        raise InputError("exists and is not a directory", path=final)
    here = Path.cwd().resolve()
    if final.resolve() == here or final.resolve() in here.parents:
        raise InputError("is the working directory or contains it: give a new folder",
                         path=final)
    if not final.is_dir() or not any(final.iterdir()):
        return
    if not overwrite:
        raise InputError("exists and is not empty: nothing was written (--overwrite "
                         "replaces it whole)", path=final)
    inside = [p for p in inputs if final.resolve() in Path(p).resolve().parents]
    if inside:
        raise InputError(f"holds an input ({inside[0]}) that --overwrite would remove",
                         path=final)
    if not os.access(final, os.W_OK | os.X_OK):
        raise InputError("cannot be replaced: no permission to remove its files", path=final)


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)                 # signal 0: only asks whether the process exists
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _remove_stale(parent: Path, name: str) -> None:
    """Remove hidden siblings of `name` left by processes that no longer run."""
    for tag in (_TMP_TAG, _OLD_TAG):
        for stale in parent.glob(f".{glob.escape(name)}{tag}*"):
            pid = stale.name[len(name) + 1 + len(tag):].split("-", 1)[0]
            if pid.isdigit() and not _process_alive(int(pid)):
                shutil.rmtree(stale, ignore_errors=True)


def _commit(tmp: Path, final: Path, overwrite: bool) -> None:
    """Rename `tmp` to `final`, moving an existing `final` aside first (then removed)."""
    if not final.exists():
        os.rename(tmp, final)
        return
    if any(final.iterdir()) and not overwrite:     # written meanwhile by someone else
        raise InputError("was written by another process meanwhile: this run's output "
                         "was discarded", path=final)
    old = Path(tempfile.mkdtemp(prefix=f".{final.name}{_OLD_TAG}{os.getpid()}-",
                                dir=tmp.parent))
    os.rename(final, old / final.name)
    os.rename(tmp, final)
    shutil.rmtree(old, ignore_errors=True)


def check_output_file(path: str | os.PathLike, *, overwrite: bool = False) -> None:
    """Before any work: `path` can be written (its folder is created and a temporary file
    made and removed there), and does not exist unless `overwrite`.

    Raises
    ------
    InputError
        Naming `path`.
    """
    target = Path(path)
    if target.is_dir():
        raise InputError("is a directory", path=target)
    if target.exists() and not overwrite:
        raise InputError("exists: nothing was written (--overwrite replaces it)", path=target)
    try:
        target.absolute().parent.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".tmp-", dir=target.absolute().parent)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise InputError(f"cannot write here: {exc.strerror or exc}", path=target) from None


#: Lock file of `directory_lock`, inside the directory.
LOCK_FILE = ".lock"


@contextlib.contextmanager
def directory_lock(path: str | os.PathLike, *, what: str = "process") -> Iterator[Path]:
    """Hold an exclusive lock on the directory `path` (created) for the block.

    The lock is an ``flock`` on ``path/.lock``, which holds the owner's pid for the
    message; the system releases it when the holder exits, however it ends (SIGKILL
    included), so a lock is never stale.

    Raises
    ------
    InputError
        Naming `path` when another process holds the lock (``what``: what it is, for the
        message, e.g. "study").
    """
    import fcntl                       # POSIX; imported here so Windows can import us

    directory = Path(path)
    try:
        directory.mkdir(parents=True, exist_ok=True)
        fd = os.open(directory / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError as exc:
        raise InputError(f"cannot write here: {exc.strerror or exc}", path=directory) from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            owner = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
            raise InputError(f"another {what} (pid {owner}) is running on it: wait for it "
                             "or give another folder", path=directory) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield directory
    finally:
        os.close(fd)                   # releases the lock
