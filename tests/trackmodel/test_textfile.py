"""Reading users' files: located errors for what pandas and the codecs raise (issue 18)."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from trackmodel.errors import InputError, finite_column
from trackmodel.textfile import read_csv_table, read_text


@pytest.mark.parametrize("data,line", [
    (b"\xff", 1), (b"a,b\n1,2\n", None), (b"a,b\n1,2\n3,\xc3\n", 3),
    ("é\nà\n".encode("utf-8") + b"\n\xe9\n", 4),
])
def test_first_bad_byte_is_located_by_line(tmp_path, data, line):
    """Reference: the line of the first undecodable byte, counted by hand in each case."""
    path = tmp_path / "x.csv"
    path.write_bytes(data)
    if line is None:
        assert read_text(path) == data.decode("utf-8")
        return
    with pytest.raises(InputError, match="not UTF-8 text") as info:
        read_text(path)
    assert info.value.line == line
    with pytest.raises(InputError) as info:
        read_csv_table(path)
    assert info.value.line == line


def test_byte_order_mark_is_dropped(tmp_path):
    path = tmp_path / "x.csv"
    path.write_bytes(b"\xef\xbb\xbflat_deg,lon_deg\n1,2\n")
    assert read_text(path).startswith("lat_deg")
    assert list(read_csv_table(path).columns) == ["lat_deg", "lon_deg"]


def test_extra_field_and_empty_file(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text("# comment\na,b\n1,2\n\n3,4,5\n")
    with pytest.raises(InputError, match="3 fields, but the header has 2") as info:
        read_csv_table(path, comment="#")
    assert info.value.line == 5          # every line of the file counted
    path.write_text("")
    with pytest.raises(InputError, match="empty file"):
        read_csv_table(path)


def test_every_row_one_field_longer_than_the_header(tmp_path):
    """pandas takes such a file's first column for the index and shifts the others
    ("time_s,speed_mps" over "0,1,7" read time 1, speed 7): refused; a trailing comma on
    every row (an empty last field) reads as written."""
    path = tmp_path / "x.csv"
    path.write_text("# a logger\ntime_s,speed_mps\n\n0,1,7\n1,2,8\n")
    with pytest.raises(InputError, match="3 fields, but the header has 2") as info:
        read_csv_table(path, comment="#")
    assert info.value.line == 4
    path.write_text("time_s,speed_mps\n0,1,\n1,2,\n")
    frame = read_csv_table(path)
    assert frame.to_dict("list") == {"time_s": [0, 1], "speed_mps": [1, 2]}


@pytest.mark.parametrize("cell,message", [
    ("abc", "'abc' is not a finite number"), (np.nan, "empty or NaN"),
    (np.float64(np.inf), "inf is not a finite number"),
])
def test_issue18_messages_never_show_numpy_reprs(cell, message):
    frame = pd.DataFrame({"x": [1.0, cell]})
    with pytest.raises(InputError) as info:
        finite_column(frame, "x", path="f.csv")
    assert str(info.value) == f"f.csv: row 2, x: {message}" + (
        " (a finite number is needed)" if message == "empty or NaN" else "")
    assert "np." not in str(info.value)
