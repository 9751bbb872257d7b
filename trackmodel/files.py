"""Atomic file output, shared by every package that writes files.

Nothing the project writes is ever left half-written: data goes to a temporary file in
the target directory, which replaces the target only when writing succeeded
(``os.replace`` is atomic on POSIX and Windows for paths on one file system).
"""
from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator, Mapping
from typing import IO

__all__ = ["atomic_write", "atomic_write_text", "atomic_write_csv"]


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
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


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
