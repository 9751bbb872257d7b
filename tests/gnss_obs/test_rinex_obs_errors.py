"""Observation files with events, and broken ones: one located error, never a partial table.

Each broken file is the shipped excerpt's first epochs with one defect made by hand; the
expected line number is counted in the test from the text, not taken from the reader.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gnss_obs.errors import GnssInputError
from gnss_obs.rinex_obs import read_rinex_obs

DATA = Path(__file__).resolve().parents[2] / "data" / "gnss"
ROVER = DATA / "rover_obs_1240.rnx"


def _lines(n_epochs: int = 3) -> list[str]:
    lines = ROVER.read_text().split("\n")
    starts = [i for i, ln in enumerate(lines) if ln.startswith(">")]
    return lines[:starts[n_epochs]]


def _epoch_lines(lines: list[str]) -> list[int]:
    return [i for i, ln in enumerate(lines) if ln.startswith(">")]


def _write(tmp_path: Path, lines: list[str], name: str = "broken.rnx") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def _raises(path: Path, line: int, what: str):
    return pytest.raises(GnssInputError, match=rf"^{re.escape(str(path))}: line {line}\b.*{what}")


def test_empty_file(tmp_path):
    path = tmp_path / "empty.rnx"
    path.write_bytes(b"")
    with _raises(path, 1, "empty file"):
        read_rinex_obs(path)


def test_header_without_end(tmp_path):
    lines = _lines()
    header = lines[:_epoch_lines(lines)[0] - 1]  # drop END OF HEADER and the body
    path = _write(tmp_path, header)
    with _raises(path, len(header), "END OF HEADER"):
        read_rinex_obs(path)


def test_unknown_version(tmp_path):
    lines = _lines()
    lines[0] = "     5.00" + lines[0][9:]
    path = _write(tmp_path, lines)
    with _raises(path, 1, "unsupported RINEX version 5.00"):
        read_rinex_obs(path)


def test_navigation_file_is_not_an_observation_file(tmp_path):
    path = DATA / "broadcast_nav.rnx"
    with _raises(path, 1, "wrong file type 'N'"):
        read_rinex_obs(path)


def test_not_rinex(tmp_path):
    path = _write(tmp_path, ["gps_time_s,x_m", "1,2"])
    with _raises(path, 1, "not a RINEX file"):
        read_rinex_obs(path)


def test_truncated_record_line(tmp_path):
    lines = _lines()
    k = _epoch_lines(lines)[1] + 3          # third satellite of the second epoch
    lines[k] = lines[k][:3 + 16 + 9]        # cut inside the second field's value
    path = _write(tmp_path, lines)
    with _raises(path, k + 1, "truncated or misaligned"):
        read_rinex_obs(path)


def test_bad_number_names_the_observation_type(tmp_path):
    lines = _lines()
    k = _epoch_lines(lines)[0] + 1          # C07: its C2I value is field 2
    field = 3 + 16
    assert lines[k].startswith("C07") and lines[k][field:field + 14].strip()
    lines[k] = lines[k][:field + 5] + "x" + lines[k][field + 6:]
    path = _write(tmp_path, lines)
    with _raises(path, k + 1, "C2I.*not a number"):
        read_rinex_obs(path)


def test_file_cut_inside_the_last_epoch(tmp_path):
    lines = _lines()
    last = _epoch_lines(lines)[-1]
    path = _write(tmp_path, lines[:last + 4])
    with _raises(path, last + 1, "announces .* records but the file ends after 3"):
        read_rinex_obs(path)


def test_missing_satellite_record(tmp_path):
    lines = _lines()
    first = _epoch_lines(lines)[0]
    del lines[first + 2]
    path = _write(tmp_path, lines)
    with _raises(path, first + 1, "but the next epoch starts after"):
        read_rinex_obs(path)


@pytest.mark.parametrize("column, text, what", [
    (31, "9", "epoch flag"),          # flags are 0-6
    (2, "20x0", "epoch year"),
])
def test_bad_epoch_line(tmp_path, column, text, what):
    lines = _lines()
    k = _epoch_lines(lines)[1]
    lines[k] = lines[k][:column] + text + lines[k][column + len(text):]
    path = _write(tmp_path, lines)
    with _raises(path, k + 1, what):
        read_rinex_obs(path)


def test_undeclared_system(tmp_path):
    lines = _lines()
    k = _epoch_lines(lines)[0] + 1
    lines[k] = "J" + lines[k][1:]
    path = _write(tmp_path, lines)
    with _raises(path, k + 1, "system 'J' not declared"):
        read_rinex_obs(path)


def test_events_flag_1_and_cycle_slips(tmp_path):
    lines = _lines(2)
    e0, e1 = _epoch_lines(lines)
    epoch0, epoch1 = lines[e0:e1], lines[e1:]
    body = (epoch0
            + ["> 2020 11 29 12 40 00.5000000  4  2",
               "NEW OBSERVER                                                COMMENT",
               "second comment                                              COMMENT",
               ">" + " " * 30 + "3  1",                 # time left blank
               "MOVED                                                       MARKER NAME",
               "> 2020 11 29 12 40 00.9000000  6  1", epoch0[1]]
            + [epoch1[0][:31] + "1" + epoch1[0][32:]] + epoch1[1:]
            + ["> 2020 11 29 12 40 01.2000000  5  0"])
    path = _write(tmp_path, lines[:e0] + body, "events.rnx")
    obs = read_rinex_obs(path)
    plain = read_rinex_obs(_write(tmp_path, lines, "plain.rnx"))
    t0 = plain.table["gps_time_s"].iloc[0]
    # the observation rows are those of the two epochs; the second now has flag 1
    expected = plain.table.assign(epoch_flag=np.where(plain.table["gps_time_s"] > t0, 1, 0))
    pd.testing.assert_frame_equal(obs.table, expected)
    ev = obs.events
    assert list(ev["epoch_flag"]) == [4, 3, 6, 5]
    assert list(ev["n_records"]) == [2, 1, 1, 0]
    assert list(ev["line"]) == [e0 + len(epoch0) + k + 1 for k in (0, 3, 5)] + [
        e0 + len(epoch0) + 7 + len(epoch1) + 1]
    np.testing.assert_array_equal(ev["gps_time_s"].to_numpy(),
                                  [t0 + 0.5, np.nan, t0 + 0.9, t0 + 1.2])
    assert ev["text"].iloc[0].splitlines()[1].startswith("second comment")
    assert ev["text"].iloc[2] == epoch0[1]


_PRINTABLE = st.characters(min_codepoint=32, max_codepoint=126)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzzed_lines_fail_only_with_our_error(tmp_path, data):
    # Any single-character edit anywhere in the file: either it still reads, or the
    # reader raises GnssInputError with a line number (never another exception).
    lines = _lines(2)
    k = data.draw(st.integers(0, len(lines) - 1), label="line")
    col = data.draw(st.integers(0, max(len(lines[k]) - 1, 0)), label="column")
    ch = data.draw(_PRINTABLE, label="char")
    lines[k] = lines[k][:col] + ch + lines[k][col + 1:]
    path = _write(tmp_path, lines, "fuzz.rnx")
    try:
        read_rinex_obs(path)
    except GnssInputError as exc:
        assert exc.line is not None and str(exc).startswith(str(path))
