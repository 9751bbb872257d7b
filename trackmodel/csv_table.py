"""Writing a pandas table as CSV quickly (pyarrow's writer), with a stated precision.

``DataFrame.to_csv(float_format="%.12g")`` formats every number in Python (~35 µs a row of
25 floats); here the numbers are rounded in NumPy and written by Arrow's C++ writer, which
prints each double in its shortest round-trip form (5-7× faster, measured in
``benchmarks/bench_speed.py``). The file is what ``to_csv(index=False)`` gives but for
these details of form, not of value:

* **Precision.** ``float_format="%.Ng"``: each float is rounded to N significant digits
  (the double nearest to that N-digit decimal, so its shortest form has at most N digits;
  the last digit can differ from printf's in near half-way cases, 1 part in 10^N).
  ``N >= 17`` or None: the shortest form that reads back to the identical double.
  ``decimals={column: d}``: those columns are rounded to ``d`` decimals instead (e.g. times
  to the µs).
* **Form.** Small numbers may be printed as ``0.00001`` where printf prints ``1e-05``;
  booleans stay ``True``/``False``; missing values (NaN, None) are empty fields.

Tables that Arrow cannot write as they are (mixed-type object columns, a string that needs
quotes) are written by pandas, with the same ``float_format`` (the slow path).
"""
from __future__ import annotations

import csv
import io
from collections.abc import Mapping
from typing import IO

import numpy as np
import numpy.typing as npt

__all__ = ["write_csv", "round_significant", "significant_digits"]

#: Significant digits from which rounding is a no-op: 17 digits identify every double.
ROUND_TRIP_DIGITS = 17
#: Powers of ten up to this exponent are exact in float64 (10^22 < 2^53 · 2^22).
_EXACT_POWER = 22


def significant_digits(float_format: str | None) -> int | None:
    """N of a ``"%.Ng"`` format; None for None (shortest round-trip form).

    Raises
    ------
    ValueError
        For any other format.
    """
    if float_format is None:
        return None
    text = float_format.strip()
    if text.startswith("%.") and text.endswith("g") and text[2:-1].isdigit():
        return int(text[2:-1])
    raise ValueError(f"float_format must be '%.Ng' or None, got {float_format!r}")


def round_significant(x: npt.ArrayLike, digits: int) -> npt.NDArray[np.float64]:
    """`x` rounded to `digits` significant decimal digits (module docstring).

    Parameters
    ----------
    x : array_like of float, shape (N,)
    digits : int
        At least 1.

    Returns
    -------
    ndarray of float, shape (N,)
        Zeros, NaN and infinities unchanged.
    """
    out = np.array(x, dtype=np.float64, copy=True)
    if digits >= ROUND_TRIP_DIGITS:
        return out
    nonzero = np.flatnonzero(np.isfinite(out) & (out != 0.0))
    y = out[nonzero]
    k = digits - 1 - np.floor(np.log10(np.abs(y))).astype(np.int64)
    up = (k >= 0) & (k <= _EXACT_POWER)
    down = (k < 0) & (k >= -_EXACT_POWER)
    scale = 10.0 ** k[up]
    y[up] = np.round(y[up] * scale) / scale         # m / 10^k: the nearest double
    scale = 10.0 ** (-k[down])
    y[down] = np.round(y[down] / scale) * scale
    for i in np.flatnonzero(~(up | down)):          # beyond 1e±22 of scale: rare, exact
        y[i] = float(f"{y[i]:.{digits - 1}e}")
    out[nonzero] = y
    return out


def write_csv(fh: IO, frame, *, float_format: str | None = None,
              decimals: Mapping[str, int] | None = None, header: bool = True) -> None:
    """Write `frame` (no index) as CSV to the open file `fh` (text or binary).

    Parameters
    ----------
    fh : file object
        Opened for writing; text files should be opened with ``newline=""``.
    frame : pandas.DataFrame
    float_format : str or None
        ``"%.Ng"``: N significant digits; None: shortest round-trip form.
    decimals : mapping of str to int, optional
        Columns rounded to this many decimals instead (absent columns are ignored).
    header : bool
        Write the column names first.
    """
    import pyarrow as pa

    digits = significant_digits(float_format)
    binary = isinstance(fh, (io.RawIOBase, io.BufferedIOBase))
    try:
        data = _arrow_csv(frame, digits, dict(decimals or {}), header)
    except (pa.ArrowInvalid, pa.ArrowTypeError, pa.ArrowNotImplementedError):
        text = frame.to_csv(index=False, header=header, float_format=float_format,
                            lineterminator="\n")
        fh.write(text.encode() if binary else text)
        return
    fh.write(data if binary else data.decode())


def _arrow_csv(frame, digits: int | None, decimals: dict[str, int], header: bool) -> bytes:
    import pyarrow as pa
    import pyarrow.csv as pacsv

    arrays = []
    for i, name in enumerate(frame.columns):
        column = frame.iloc[:, i]
        values = column.to_numpy()
        if values.dtype == np.bool_:
            arrays.append(pa.array(np.where(values, "True", "False")))
        elif values.dtype.kind == "f":
            if name in decimals:
                values = np.round(values.astype(np.float64), decimals[name])
            elif digits is not None:
                values = round_significant(values, digits)
            arrays.append(pa.array(values, from_pandas=True))      # NaN -> empty field
        else:
            arrays.append(pa.array(column, from_pandas=True))
    table = pa.Table.from_arrays(arrays, names=[str(name) for name in frame.columns])
    sink = io.BytesIO()
    if header:                       # as pandas writes it (Arrow quotes every name)
        names = io.StringIO()
        csv.writer(names, lineterminator="\n").writerow(table.column_names)
        sink.write(names.getvalue().encode())
    # no quotes: Arrow's "needed" would quote every string; a value that needs quotes
    # (a delimiter, quote or line break inside) raises ArrowInvalid -> pandas writes it
    pacsv.write_csv(table, sink, pacsv.WriteOptions(include_header=False,
                                                     quoting_style="none"))
    return sink.getvalue()
