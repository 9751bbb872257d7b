"""Vectorised fixed-width text parsing shared by the RINEX and SP3 readers.

RINEX and SP3 are Fortran-formatted: every field has fixed columns. A reader gathers the
lines it wants, pads them into one ``(n_lines, width)`` byte matrix (`char_table`) and
converts whole columns at once (`parse_floats`, `parse_ints`), so no Python ``float()``
runs per value. NumPy's bytes -> float64 cast rounds like ``float()``, so the values are
the ones the text states. A field that does not convert is reported as a
`GnssInputError` naming the file, the 1-based line number and the field.

Also reads a file's bytes, expanding Hatanaka-compressed (``.crx``) and gzip/Unix
compressed RINEX through the ``hatanaka`` package, and ``.zip`` (one member) and ``.bz2``
archives through the standard library (their content may itself be Hatanaka/gzip).
"""
from __future__ import annotations

import bz2
import gzip
import io
import os
import zipfile
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from gnss_obs.errors import GnssInputError
from gnss_obs.gpstime import days_in_month

__all__ = ["read_text_bytes", "split_lines", "char_table", "parse_floats", "parse_ints",
           "field_text", "calendar_fields", "check_calendar", "check_ascii",
           "check_last_line"]

_SPACE = ord(" ")
_NAN = b"nan"
#: Leading bytes of compressed files: gzip, Unix compress (.Z), Hatanaka (CRINEX).
_GZIP_MAGIC = b"\x1f\x8b"
_COMPRESS_MAGIC = b"\x1f\x9d"
_CRINEX_LABEL = b"COMPACT RINEX FORMAT"
_CRINEX_HEAD_BYTES = 200
_BZIP2_MAGIC = b"BZh"
_ZIP_MAGIC = b"PK\x03\x04"


def read_text_bytes(path: str | os.PathLike) -> bytes:
    """The bytes of a RINEX/SP3 file, decompressed, with ``\\n`` line ends.

    Parameters
    ----------
    path : str or os.PathLike
        Plain, gzip (``.gz``), Unix-compressed (``.Z``), Hatanaka (``.crx``/``.??d``),
        bzip2 (``.bz2``) or zip (``.zip``, exactly one file inside) file; recognised by
        their leading bytes, not by the name.

    Raises
    ------
    GnssInputError
        When the file cannot be opened or decompressed, or a zip archive does not hold
        exactly one file.
    """
    try:
        with open(path, "rb") as fh:
            data = fh.read()
    except OSError as exc:
        raise GnssInputError(f"cannot read: {exc.strerror or exc}", path=path) from None
    data = _unarchive(path, data)
    is_crinex = _CRINEX_LABEL in data[:_CRINEX_HEAD_BYTES]
    if data[:2] in (_GZIP_MAGIC, _COMPRESS_MAGIC) or is_crinex:
        data = _decompress(path, data)
    if b"\r" in data:
        data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    return data


def _unarchive(path, data: bytes) -> bytes:
    """Expand bzip2 and single-member zip data with the standard library (else unchanged)."""
    if data[:3] == _BZIP2_MAGIC:
        try:
            return bz2.decompress(data)
        except (OSError, ValueError, EOFError) as exc:
            raise GnssInputError(f"corrupt bzip2 data: {exc}", path=path) from None
    if data[:4] == _ZIP_MAGIC:
        try:
            with zipfile.ZipFile(io.BytesIO(data)) as archive:
                members = [m for m in archive.infolist() if not m.is_dir()]
                if len(members) != 1:
                    names = ", ".join(m.filename for m in members) or "none"
                    raise GnssInputError(f"zip archive holds {len(members)} files ({names}): "
                                         "expected exactly one RINEX/SP3 file", path=path)
                return archive.read(members[0])
        except (zipfile.BadZipFile, OSError, NotImplementedError) as exc:
            raise GnssInputError(f"corrupt or unsupported zip archive: {exc}",
                                 path=path) from None
    return data


def _decompress(path, data: bytes) -> bytes:
    """Expand gzip / .Z / Hatanaka bytes (``hatanaka`` handles all three)."""
    try:
        import hatanaka  # optional: only compressed files need it
    except ImportError:
        if data[:2] == _GZIP_MAGIC:
            try:
                return gzip.decompress(data)
            except (OSError, EOFError) as exc:
                raise GnssInputError(f"corrupt gzip data: {exc}", path=path) from None
        raise GnssInputError("compressed RINEX needs the 'hatanaka' package", path=path) from None
    try:
        return hatanaka.decompress(data)
    except Exception as exc:  # hatanaka raises bare ValueError/OSError/RuntimeError
        raise GnssInputError(f"cannot decompress: {exc}", path=path) from None


def split_lines(data: bytes) -> list[bytes]:
    """Lines of `data` without their ``\\n`` (a final empty line is dropped)."""
    lines = data.split(b"\n")
    if lines and lines[-1] == b"":
        lines.pop()
    return lines


_ASCII_END = 0x80
_NEWLINE = ord("\n")


def check_ascii(lines: list[bytes], first_line: int, path, *,
                free_text: Callable[[bytes], bool] | None = None) -> None:
    """Raise at the first byte of `lines` outside 7-bit ASCII (RINEX and SP3 are ASCII).

    Parameters
    ----------
    lines : list of bytes
    first_line : int
        1-based file line of ``lines[0]``.
    path : str or os.PathLike
        File name for the message.
    free_text : callable(line) -> bool, optional
        Lines where any byte is allowed (e.g. SP3 comments).

    Raises
    ------
    GnssInputError
        Naming the line, the column and the byte.
    """
    data = b"\n".join(lines)
    codes = np.frombuffer(data, dtype=np.uint8)
    high = np.flatnonzero(codes >= _ASCII_END)
    if high.size == 0:
        return
    ends = np.flatnonzero(codes == _NEWLINE)
    line_of = np.searchsorted(ends, high)
    for k in np.unique(line_of):
        if free_text is not None and free_text(lines[k]):
            continue
        pos = int(high[np.searchsorted(line_of, k)])
        column = pos - (int(ends[k - 1]) + 1 if k else 0) + 1
        raise GnssInputError(f"byte 0x{codes[pos]:02x} is not ASCII text: a corrupted or "
                             "binary file?", path=path, line=first_line + int(k),
                             column=f"column {column}")


def check_last_line(data: bytes, lines: list[bytes], width: int, path) -> None:
    """Raise when the file ends without a line end inside a line shorter than `width`.

    A copy or download that stops in mid-line leaves a last line without its ``\n``;
    when that line is shorter than a full record line the cut may have taken digits off
    its last number (``1.2345`` of ``1.234567e-05``), which no field check can see.

    Raises
    ------
    GnssInputError
        Naming the last line and the column where it stops.
    """
    if not data or data.endswith(b"\n") or not lines:
        return
    used = len(lines[-1].rstrip())
    if 0 < used < width:
        raise GnssInputError(f"the file ends inside this line (no line end; it stops at "
                             f"column {used} of {width}): truncated? (if the line is "
                             "complete, add the missing line end)", path=path, line=len(lines))


def char_table(lines: list[bytes], width: int) -> npt.NDArray[np.uint8]:
    """Pad or cut `lines` to `width` bytes and stack them.

    Returns
    -------
    ndarray of uint8, shape (len(lines), width)
        Byte codes, right-padded with spaces.
    """
    if not lines:
        return np.empty((0, width), dtype=np.uint8)
    joined = b"".join([ln[:width].ljust(width) for ln in lines])
    return np.frombuffer(joined, dtype=np.uint8).reshape(len(lines), width)


def field_text(chars: npt.NDArray[np.uint8], start: int, stop: int) -> np.ndarray:
    """Columns ``start:stop`` of a char table as a bytes array, shape (n,), dtype ``S<w>``."""
    block = np.ascontiguousarray(chars[:, start:stop])
    return block.view(f"S{stop - start}").ravel()


def _blank(chars: npt.NDArray[np.uint8], start: int, stop: int) -> np.ndarray:
    return (chars[:, start:stop] == _SPACE).all(axis=1)


def parse_floats(chars: npt.NDArray[np.uint8], start: int, stop: int, *,
                 path, lines: npt.NDArray[np.int64], column: str,
                 d_exponent: bool = False) -> npt.NDArray[np.float64]:
    """Convert one fixed-width column of real numbers; blank fields become NaN.

    Parameters
    ----------
    chars : ndarray of uint8, shape (n, width)
        Char table from `char_table`.
    start, stop : int
        0-based column range of the field.
    path : str or os.PathLike
        File name for error messages.
    lines : ndarray of int, shape (n,)
        1-based file line number of each row, for error messages.
    column : str
        Field name for error messages.
    d_exponent : bool
        Accept Fortran ``D`` exponents (``1.5D+03``), as RINEX navigation files use.

    Returns
    -------
    ndarray of float64, shape (n,)

    Raises
    ------
    GnssInputError
        At the first field that is not a number.
    """
    text = field_text(chars, start, stop)
    if d_exponent:
        block = chars[:, start:stop]
        if ((block == ord("D")) | (block == ord("d"))).any():
            text = np.char.replace(np.char.replace(text, b"D", b"E"), b"d", b"e")
    text = np.where(_blank(chars, start, stop), _NAN, text)
    try:
        return text.astype(np.float64)
    except ValueError:
        bad = _first_bad(text, float)
        raise GnssInputError(f"{text[bad].decode(errors='replace').strip()!r} is not a number",
                             path=path, line=int(lines[bad]), column=column) from None


def parse_ints(chars: npt.NDArray[np.uint8], start: int, stop: int, *,
               path, lines: npt.NDArray[np.int64], column: str,
               blank: int = 0) -> npt.NDArray[np.int64]:
    """Convert one fixed-width column of integers; blank fields become `blank`.

    Digits and spaces only (an optional ``-`` sign before the digits). Same parameters
    and error as `parse_floats`.
    """
    block = chars[:, start:stop].astype(np.int64)
    digit = (block >= ord("0")) & (block <= ord("9"))
    minus = block == ord("-")
    space = block == _SPACE
    ok = (digit | minus | space).all(axis=1) & (minus.sum(axis=1) <= 1)
    width = stop - start
    if width:
        # a sign must precede every digit
        first_digit = np.where(digit.any(axis=1), digit.argmax(axis=1), width)
        minus_at = np.where(minus.any(axis=1), minus.argmax(axis=1), -1)
        ok &= minus_at < first_digit
        ok &= ~(minus.any(axis=1) & ~digit.any(axis=1))
    if not ok.all():
        bad = int(np.flatnonzero(~ok)[0])
        raw = bytes(chars[bad, start:stop]).decode(errors="replace").strip()
        raise GnssInputError(f"{raw!r} is not an integer", path=path,
                             line=int(lines[bad]), column=column)
    digits = np.where(digit, block - ord("0"), 0)
    # place value of each digit = number of digits to its right (spaces are skipped)
    right = digit[:, ::-1].cumsum(axis=1)[:, ::-1] - digit
    value = (digits * 10 ** right).sum(axis=1)
    value = np.where(minus.any(axis=1), -value, value)
    return np.where(digit.any(axis=1), value, blank)


def calendar_fields(chars, columns: dict[str, tuple[int, int]], second: tuple[int, int],
                    lines, path) -> dict[str, np.ndarray]:
    """Calendar label fields of epoch lines (``columns``: name -> (start, stop)).

    Returns arrays ``year month day hour minute`` (int) and ``second`` (float), shape (n,).
    """
    fields = {}
    for name, (a, b) in columns.items():
        fields[name] = parse_ints(chars, a, b, path=path, lines=lines, column=f"epoch {name}",
                                  blank=-1)
        if (fields[name] < 0).any():
            i = int(np.flatnonzero(fields[name] < 0)[0])
            raise GnssInputError(f"epoch {name} missing or negative", path=path,
                                 line=int(lines[i]), column=f"epoch {name}")
    sec = parse_floats(chars, *second, path=path, lines=lines, column="epoch second")
    if np.isnan(sec).any():
        raise GnssInputError("epoch second missing", path=path,
                             line=int(lines[np.flatnonzero(np.isnan(sec))[0]]),
                             column="epoch second")
    fields["second"] = sec
    check_calendar(fields, lines, path)
    return fields


#: Largest value of each time-of-day field; seconds up to 60.999... (a leap second).
_CALENDAR_MAX = {"hour": 23, "minute": 59}
_MONTHS = 12
_SECOND_LIMIT = 61.0


def check_calendar(fields: dict[str, np.ndarray], lines, path) -> None:
    """Reject a calendar label that names no instant (month 13, day 45, hour 24...).

    Parameters
    ----------
    fields : dict of str to ndarray, shape (n,)
        ``year month day hour minute second`` as `calendar_fields` returns them.
    lines : ndarray of int, shape (n,)
        1-based file line of each label.

    Raises
    ------
    GnssInputError
        At the first label out of range, naming the field and its value.
    """
    month = np.asarray(fields["month"])
    bad = {"month": (month < 1) | (month > _MONTHS)}
    ok_month = np.clip(month, 1, _MONTHS)
    day = np.asarray(fields["day"])
    bad["day"] = (day < 1) | (day > days_in_month(fields["year"], ok_month))
    for name, top in _CALENDAR_MAX.items():
        bad[name] = np.asarray(fields[name]) > top
    bad["second"] = ~(np.asarray(fields["second"]) < _SECOND_LIMIT)
    for name, wrong in bad.items():
        if wrong.any():
            i = int(np.flatnonzero(wrong)[0])
            label = (f"{fields['year'][i]:04d}-{month[i]:02d}-{day[i]:02d} "
                     f"{fields['hour'][i]:02d}:{fields['minute'][i]:02d}:"
                     f"{fields['second'][i]:06.3f}")
            raise GnssInputError(f"{name} {fields[name][i]:g} out of range ({label} is no "
                                 "date and time)", path=path, line=int(np.asarray(lines)[i]),
                                 column=f"epoch {name}")


def _first_bad(text: np.ndarray, convert) -> int:
    """Index of the first element of `text` that `convert` rejects."""
    for i, item in enumerate(text):
        try:
            convert(item)
        except ValueError:
            return i
    return 0
