"""Reading a user's text and CSV files with located one-line errors, for every package.

pandas and the codecs raise their own exceptions for a malformed file — a byte that is not
UTF-8 (`UnicodeDecodeError`), a row with more fields than the header
(`pandas.errors.ParserError`), an empty file (`pandas.errors.EmptyDataError`) — which name
neither the file nor, usefully, the line. `read_text` and `read_csv_table` turn each into
the reader's own `trackmodel.errors.InputError` subclass, located at the file and the line
(1-based, every line of the file counted):

    survey.csv: line 3: 3 fields, but the header has 2
    survey.csv: line 2: not UTF-8 text (byte 0xff)

A file that cannot be opened raises `OSError` as ever (the command line reports it in one
line with the file name).
"""
from __future__ import annotations

import csv
import os
import re
import warnings

import pandas as pd

from trackmodel.errors import InputError

__all__ = ["read_text", "read_csv_table", "decode_error"]

_FIELDS = re.compile(r"Expected (\d+) fields in line (\d+), saw (\d+)")


def decode_error(path: str | os.PathLike, *, error: type[InputError] = InputError,
                 data: bytes | None = None) -> InputError:
    """The located error of a file that is not UTF-8: the line and value of its first bad
    byte (`data`: the file's bytes, read from `path` when not given)."""
    if data is None:
        with open(path, "rb") as fh:
            data = fh.read()
    try:
        data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        return error(f"not UTF-8 text (byte 0x{data[exc.start]:02x})", path=path, line=line)
    return error("not UTF-8 text", path=path)


def read_text(path: str | os.PathLike, *, error: type[InputError] = InputError) -> str:
    """The text of a UTF-8 file (a leading byte-order mark dropped).

    Raises
    ------
    InputError (`error`)
        Located at the line of the first byte that is not UTF-8.
    OSError
        If the file cannot be read.
    """
    with open(path, "rb") as fh:
        data = fh.read()
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise decode_error(path, error=error, data=data) from None


def _longer_rows(path, error: type[InputError], comment: str | None) -> InputError:
    """The located error of a table whose every row is longer than its header: the first
    data row's line and width (comment and blank lines skipped, as pandas does)."""
    rows = ((k, line) for k, line in enumerate(read_text(path, error=error).splitlines(), 1)
            if line.strip() and not (comment and line.lstrip().startswith(comment)))
    (_, header), (line, first) = next(rows), next(rows)
    widths = [len(next(csv.reader([text]))) for text in (header, first)]
    return error(f"{widths[1]} fields, but the header has {widths[0]}", path=path, line=line)


def read_csv_table(path: str | os.PathLike, *, error: type[InputError] = InputError,
                   **read_csv_kwargs) -> pd.DataFrame:
    """`pandas.read_csv` of a user's file, with its failures as located `error` s.

    Parameters
    ----------
    path : str or os.PathLike
    error : type
        The reader's `InputError` subclass.
    **read_csv_kwargs
        Passed to `pandas.read_csv` (``comment``, ``dtype``, ...).

    Raises
    ------
    InputError (`error`)
        Empty file; a byte that is not UTF-8 (its line); a row with more fields than the
        header (its line), or every row (empty trailing fields, a trailing comma, are
        read); any other tokenizing failure (pandas' words, one line).
    OSError
        If the file cannot be read.
    """
    # index_col=False: a row one field longer than the header everywhere would otherwise
    # make pandas take the first column for the index and shift the others silently
    # ("time_s,speed_mps" over "0,1,7" read time 1, speed 7); trailing commas still read.
    # Without a header row (header=None) the first row sets the width: nothing to shift
    kwargs = (read_csv_kwargs if read_csv_kwargs.get("header", "infer") is None
              else {"index_col": False, **read_csv_kwargs})
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("error", category=pd.errors.ParserWarning,
                                    message="Length of header")
            return pd.read_csv(path, encoding="utf-8", **kwargs)
    except pd.errors.ParserWarning:
        raise _longer_rows(path, error, read_csv_kwargs.get("comment")) from None
    except UnicodeDecodeError:
        raise decode_error(path, error=error) from None
    except pd.errors.EmptyDataError:
        raise error("empty file", path=path) from None
    except pd.errors.ParserError as exc:
        message = " ".join(str(exc).split())
        found = _FIELDS.search(message)
        if found:
            expected, line, saw = (int(g) for g in found.groups())
            raise error(f"{saw} fields, but the header has {expected}", path=path,
                        line=line) from None
        message = message.replace("Error tokenizing data. C error: ", "")
        raise error(f"not a CSV table ({message})", path=path) from None
