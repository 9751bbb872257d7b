"""The fast CSV writer against pandas' own ``to_csv`` and printf's ``%.Ng``.

References: printf (``"%.12g" % x``, parsed back) for the rounding; pandas' writer for the
table (read back by pandas: the same columns, dtypes and values); Python's shortest
``repr`` for the digit count.
"""
from __future__ import annotations

import io
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trackmodel.csv_table import round_significant, significant_digits, write_csv
from trackmodel.files import atomic_write_csv

DIGITS = 12
#: One unit in the last (12th) significant digit: a near half-way case may round the other
#: way than printf, which rounds the exact binary value (csv_table's docstring).
LAST_DIGIT_REL = 10.0 ** (1 - DIGITS)


def _significant_digits_of(x: float) -> int:
    mantissa = repr(abs(x)).split("e")[0].replace(".", "").lstrip("0").rstrip("0")
    return max(len(mantissa), 1)


@settings(max_examples=400, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False, allow_subnormal=False))
def test_rounding_matches_printf_to_the_last_digit(x):
    y = float(round_significant(np.array([x]), DIGITS)[0])
    printf = float(f"{x:.{DIGITS}g}")
    assert y == printf or abs(y - printf) <= LAST_DIGIT_REL * abs(printf)
    assert _significant_digits_of(y) <= DIGITS


def test_rounding_keeps_zero_nan_inf_and_the_extremes():
    x = np.array([0.0, -0.0, np.nan, np.inf, -np.inf, 7.42674671761234e-12, 1.2345678901234e-300,
                  1.7976931348623157e308, 123456789012345678.0])
    y = round_significant(x, DIGITS)
    assert np.array_equal(y[:5], x[:5], equal_nan=True) and math.copysign(1, y[1]) == -1
    for xi, yi in zip(x[5:], y[5:]):
        assert yi == float(f"{xi:.{DIGITS}g}")             # beyond 1e±22: the exact path


def _frame(rng: np.random.Generator) -> pd.DataFrame:
    n = 500
    return pd.DataFrame({
        "time_s": np.arange(n) * 0.01 + 1e-9 * rng.standard_normal(n),
        "gps_time_s": 1_290_688_800.0 + np.arange(n) * 0.01,
        "s_m": rng.uniform(0, 2e4, n), "sigma_m": 10.0 ** rng.uniform(-14, 3, n),
        "epoch": np.arange(n), "sv": pd.array([f"G{k % 32 + 1:02d}" for k in range(n)],
                                             dtype="string"),
        "accepted": rng.random(n) < 0.5,
        "fault_probability": np.where(rng.random(n) < 0.3, np.nan, rng.random(n)),
    })


def test_table_reads_back_as_pandas_writes_it(rng):
    frame = _frame(rng)
    ours = io.StringIO()
    write_csv(ours, frame, float_format="%.12g")
    theirs = frame.to_csv(index=False, float_format="%.12g")
    a = pd.read_csv(io.StringIO(ours.getvalue()))
    b = pd.read_csv(io.StringIO(theirs))
    assert list(a.columns) == list(b.columns) and (a.dtypes == b.dtypes).all()
    assert ours.getvalue().splitlines()[0] == theirs.splitlines()[0]
    for name in ("epoch", "sv", "accepted"):
        assert a[name].equals(b[name]), name
    floats = ["time_s", "gps_time_s", "s_m", "sigma_m", "fault_probability"]
    np.testing.assert_allclose(a[floats], b[floats], rtol=LAST_DIGIT_REL, atol=0)
    assert a["fault_probability"].isna().equals(frame["fault_probability"].isna())


#: One unit in the 6th decimal: a near half-way case may round the other way than %.6f.
ATOL_TIME_S = 1e-6


def _column(text: str, name: str) -> np.ndarray:
    """A column parsed by Python's float (exact), not by pandas' parser."""
    lines = text.splitlines()
    j = lines[0].split(",").index(name)
    return np.array([float(line.split(",")[j] or "nan") for line in lines[1:]])


def test_decimals_round_named_columns_only(rng):
    frame = _frame(rng)
    out = io.BytesIO()
    write_csv(out, frame, float_format="%.12g", decimals={"time_s": 6, "gps_time_s": 6,
                                                          "absent": 3})
    text = out.getvalue().decode()
    for name in ("time_s", "gps_time_s"):     # to the µs, as printf's %.6f
        back = _column(text, name)
        np.testing.assert_allclose(back, [float(f"{x:.6f}") for x in frame[name]],
                                   rtol=0, atol=ATOL_TIME_S)
        assert np.all(np.abs(back - frame[name]) <= 0.5e-6 + np.spacing(back))
    assert _column(text, "gps_time_s")[7] == 1_290_688_800.07   # %.12g keeps 10 ms only
    np.testing.assert_allclose(_column(text, "s_m"), frame["s_m"], rtol=LAST_DIGIT_REL)


def test_no_float_format_round_trips_exactly(rng):
    frame = pd.DataFrame({"x": rng.standard_normal(1000) * 10.0 ** rng.integers(-20, 20, 1000)})
    out = io.StringIO()
    write_csv(out, frame)
    assert np.array_equal(_column(out.getvalue(), "x"), frame["x"].to_numpy())


def test_strings_that_need_quotes_and_mixed_objects_are_written_as_pandas_does(tmp_path):
    frame = pd.DataFrame({"name": ["a,b", 'say "hi"', "plain"], "mixed": [1, "x", None],
                          "v": [0.1 + 0.2, 1e-5, np.nan]})
    atomic_write_csv(tmp_path / "t.csv", frame, float_format="%.12g")
    assert (tmp_path / "t.csv").read_text() == frame.to_csv(index=False, float_format="%.12g")


def test_appending_without_header(rng):
    frame = _frame(rng)
    out = io.StringIO()
    write_csv(out, frame.iloc[:200], float_format="%.12g")
    write_csv(out, frame.iloc[200:], float_format="%.12g", header=False)
    whole = io.StringIO()
    write_csv(whole, frame, float_format="%.12g")
    assert out.getvalue() == whole.getvalue()


@pytest.mark.parametrize("fmt", ["%.3f", "%e", "{:.3g}", "%.g"])
def test_only_significant_digit_formats(fmt):
    with pytest.raises(ValueError, match="float_format"):
        significant_digits(fmt)
