"""RINEX observation files (3.0x and 2.1x) -> a tidy observation table.

`read_rinex_obs` returns a `RinexObs`: the header as an `ObsHeader` and a DataFrame with
one row per epoch × satellite × signal, sorted by (``gps_time_s``, ``sv``, ``signal``):

=================  =======  ==========================================================
column             dtype    meaning
=================  =======  ==========================================================
``gps_time_s``     float64  epoch, s since the GPS epoch (converted once from the file's
                            time system with `gnss_obs.gpstime.to_gps_time_s`)
``sv``             str      satellite, ``"G05"``
``system``         str      system letter ``G R E C J I S``
``prn``            int      satellite number
``signal``         str      band + attribute (``"1C"``, ``"5Q"``, ``"2W"``)
``band``           int      RINEX band number (``1`` for ``1C``)
``pseudorange_m``  float64  code ``C``, m (NaN when absent, as for the next three)
``carrier_cycles`` float64  carrier phase ``L``, cycles
``doppler_hz``     float64  Doppler ``D``, Hz (range rate = -wavelength × D)
``cn0_dbhz``       float64  signal strength ``S`` (dB-Hz when the header says DBHZ)
``lli``            int      carrier loss-of-lock indicator (0 when blank)
``ssi``            int      signal-strength digit 1–9 (0 when blank)
``epoch_flag``     int      0 OK, 1 power failure since the previous epoch
=================  =======  ==========================================================

Epoch flags 2–5 (events: antenna moving, new site, header records, external event) and
6 (cycle-slip records) carry no observations: they are rows of `RinexObs.events`
(``gps_time_s`` NaN when the event line leaves the time blank, ``epoch_flag``, ``line``,
``n_records``, ``text`` = the event's records joined by newlines). Header records inside
a flag-4 event are kept there as text and not applied. Observation types other than
``C L D S`` (e.g. GLONASS channel ``X``) are skipped. The receiver clock offset of the
epoch line is not read. RINEX 2 observation codes are mapped to RINEX 3 signals as
documented in `gnss_obs._rinex2_obs`.

References: RINEX 3.04 (IGS/RTCM, 2018) §5.3, §A.3–A.5; RINEX 2.11 (Gurtner & Estey 2007).
"""
from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import pandas as pd

from gnss_obs import _rinex2_obs
from gnss_obs._fixedwidth import (
    calendar_fields,
    char_table,
    check_ascii,
    parse_ints,
    read_text_bytes,
    split_lines,
)
from gnss_obs._obs_checks import check_declarations
from gnss_obs._obs_header import parse_obs_header
from gnss_obs._obs_records import EpochWalk, flag_and_count, tidy_observations
from gnss_obs._rinex_header import warn_lenient
from gnss_obs.errors import GnssInputError
from gnss_obs.gpstime import calendar_to_gps_time_s, to_gps_time_s

__all__ = ["ObsHeader", "RinexObs", "read_rinex_obs", "EVENT_COLUMNS"]

log = logging.getLogger(__name__)

#: Columns of `RinexObs.events`.
EVENT_COLUMNS = ["gps_time_s", "epoch_flag", "line", "n_records", "text"]
#: Epoch flags that carry observations; 2–5 are events, 6 cycle-slip records.
_OBSERVATION_FLAGS = (0, 1)


@dataclass(frozen=True, kw_only=True, eq=False)
class ObsHeader:
    """The parts of a RINEX observation header the project uses.

    Attributes
    ----------
    obs_types : dict of str to list of str
        Observation types per system letter, RINEX 3 codes in file order
        (``{"G": ["C1C", "L1C", "D1C", "S1C"]}``).
    first_obs_gps_time_s : float
        ``TIME OF FIRST OBS`` (or the first epoch), s since the GPS epoch.
    version : float
        Format version (3.04, 2.11...).
    marker_name, receiver, antenna : str
        ``MARKER NAME``, receiver type and antenna type.
    approx_position_e : ndarray, shape (3,)
        ``APPROX POSITION XYZ``, ECEF, m (zeros when absent).
    interval_s : float or None
        Nominal epoch interval, s.
    time_system : str
        Time system of the file's epochs (``"GPS"``, ``"GAL"``, ``"BDT"``, ``"GLO"``...).
    leap_seconds : int or None
        ``LEAP SECONDS`` (GPST - UTC, s) when given.
    glonass_slots : dict of str to int
        GLONASS satellite -> FDMA frequency channel k (``{"R01": 1}``).
    signal_strength_unit : str
        ``SIGNAL STRENGTH UNIT`` (``"DBHZ"``) or empty.
    last_obs_gps_time_s : float or None
        ``TIME OF LAST OBS`` when given, s since the GPS epoch.
    n_satellites : int or None
        ``# OF SATELLITES`` when given.
    obs_counts : dict of str to list of int
        ``PRN / # OF OBS``: satellite -> number of observations of each type, in the
        order of its system's types (empty when the header has none).
    """

    obs_types: dict[str, list[str]]
    first_obs_gps_time_s: float
    version: float = 3.04
    marker_name: str = ""
    receiver: str = ""
    antenna: str = ""
    approx_position_e: np.ndarray = field(default_factory=lambda: np.zeros(3))
    interval_s: float | None = None
    time_system: str = "GPS"
    leap_seconds: int | None = None
    glonass_slots: dict[str, int] = field(default_factory=dict)
    signal_strength_unit: str = "DBHZ"
    last_obs_gps_time_s: float | None = None
    n_satellites: int | None = None
    obs_counts: dict[str, list[int]] = field(default_factory=dict)

    @property
    def systems(self) -> list[str]:
        """System letters with declared observation types."""
        return list(self.obs_types)


def _empty_events() -> pd.DataFrame:
    return pd.DataFrame({c: pd.Series(dtype=t) for c, t in
                         zip(EVENT_COLUMNS, ("float64", "int64", "int64", "int64", "object"))})


@dataclass(frozen=True, eq=False)
class RinexObs:
    """A read observation file: header, tidy table (module docstring), events, and the
    file it was read from (None when built in memory, e.g. simulated)."""

    header: ObsHeader
    table: pd.DataFrame
    events: pd.DataFrame = field(default_factory=_empty_events)
    path: str | None = None


def read_rinex_obs(path: str | os.PathLike, *, systems: str | None = None) -> RinexObs:
    """Read a RINEX 3.0x or 2.1x observation file.

    Parameters
    ----------
    path : str or os.PathLike
        Plain, gzip, ``.Z`` or Hatanaka-compressed observation file.
    systems : str, optional
        System letters to keep, e.g. ``"GE"`` (all by default).

    Returns
    -------
    RinexObs
        Header, observation table (columns in the module docstring) and events.

    Raises
    ------
    GnssInputError
        One line with the file and line number for an empty, truncated or malformed file
        (an epoch or record cut short, a byte that is not ASCII, a date such as month 13),
        a version other than 2.xx/3.xx, or a file that is not an observation file.

    Notes
    -----
    A file that holds fewer epochs or satellites than its header declares (``TIME OF
    FIRST/LAST OBS``, ``# OF SATELLITES``, ``PRN / # OF OBS``) is read, with one warning
    giving the counts (`gnss_obs._obs_checks`).
    """
    lines = split_lines(read_text_bytes(path))
    head = parse_obs_header(lines, path)
    warn_lenient(log, path, head.notes)
    body = lines[head.body_start:]
    check_ascii(body, head.body_start + 1, path)
    if int(head.version) == 2:
        walk = _rinex2_obs.walk_epochs(body, head.body_start + 1, head.obs_types, path)
    else:
        walk = _walk_epochs_v3(body, head.body_start + 1, path)
    t = _epoch_gps_time_s(walk.epoch_fields, head.time_system, head.leap_seconds)
    table = tidy_observations(walk.records, walk.record_line, walk.record_epoch,
                              epoch_gps_time_s=t, epoch_flag=walk.epoch_flag,
                              obs_types=head.obs_types, scale=head.scale, systems=systems,
                              path=path)
    values = dict(head.values)
    if "first_obs_gps_time_s" not in values:
        values["first_obs_gps_time_s"] = float(t[0]) if len(t) else float("nan")
    header = ObsHeader(**values)
    check_declarations(header, t, table, systems=systems,
                       first_declared=head.first_obs_labels is not None, path=path)
    events = _events_frame(walk.events, head.time_system, head.leap_seconds)
    log.debug("%s: %d epochs, %d rows, %d events", path, len(t), len(table), len(events))
    return RinexObs(header, table, events, os.fspath(path))


def _epoch_gps_time_s(fields: dict[str, np.ndarray], time_system: str,
                      leap_seconds: int | None) -> npt.NDArray[np.float64]:
    labels = calendar_to_gps_time_s(fields["year"], fields["month"], fields["day"],
                                    fields["hour"], fields["minute"], fields["second"])
    return to_gps_time_s(labels, time_system, leap_seconds=leap_seconds)


def _events_frame(events: list[dict], time_system: str, leap_seconds: int | None) -> pd.DataFrame:
    if not events:
        return _empty_events()
    df = pd.DataFrame(events)
    labels = df.pop("time_label_s").to_numpy(dtype=np.float64)
    df.insert(0, "gps_time_s", to_gps_time_s(labels, time_system, leap_seconds=leap_seconds))
    return df[EVENT_COLUMNS]


#: RINEX 3 epoch line: column ranges of the calendar fields (0-based, stop exclusive).
_V3_EPOCH_COLUMNS = {"year": (2, 6), "month": (7, 9), "day": (10, 12), "hour": (13, 15),
                     "minute": (16, 18)}
_V3_SECOND = (18, 29)
_V3_FLAG = (31, 32)
_V3_COUNT = (32, 35)


def _event(body, i, flag, count, first_line, time_label_s) -> dict:
    text = b"\n".join(body[i + 1:i + 1 + count]).decode("ascii", errors="replace")
    return {"time_label_s": time_label_s, "epoch_flag": flag, "line": first_line + i,
            "n_records": count, "text": text}


def _walk_epochs_v3(body: list[bytes], first_line: int, path) -> EpochWalk:
    """Locate the epoch records of a RINEX 3 body (``first_line``: file line of body[0])."""
    starts, counts, events = [], [], []
    i, n = 0, len(body)
    while i < n:
        line = body[i]
        if line[:1] != b">":
            if not line.strip():
                i += 1
                continue
            raise GnssInputError("expected an epoch record starting with '>'", path=path,
                                 line=first_line + i)
        flag, count = flag_and_count(line, _V3_FLAG, _V3_COUNT, first_line + i, path)
        found = next((j for j in range(i + 1, min(i + 1 + count, n))
                      if body[j][:1] == b">"), min(i + 1 + count, n)) - i - 1
        if found < count:
            where = "the file ends" if i + 1 + found == n else "the next epoch starts"
            raise GnssInputError(f"epoch announces {count} records but {where} after {found}",
                                 path=path, line=first_line + i)
        if flag in _OBSERVATION_FLAGS:
            starts.append(i)
            counts.append(count)
        else:
            events.append(_event(body, i, flag, count, first_line,
                                 _event_time_label(line, first_line + i, path)))
        i += 1 + count
    starts_a = np.asarray(starts, dtype=np.int64)
    counts_a = np.asarray(counts, dtype=np.int64)
    record_epoch = np.repeat(np.arange(len(starts_a)), counts_a)
    offset = np.arange(len(record_epoch)) - np.repeat(np.cumsum(counts_a) - counts_a, counts_a)
    idx = starts_a[record_epoch] + 1 + offset
    records = [body[k] for k in idx]
    epoch_lines = first_line + starts_a
    chars = char_table([body[k] for k in starts], _V3_COUNT[1])
    fields = calendar_fields(chars, _V3_EPOCH_COLUMNS, _V3_SECOND, epoch_lines, path)
    flags = parse_ints(chars, *_V3_FLAG, path=path, lines=epoch_lines, column="epoch flag")
    return EpochWalk(records, first_line + idx, record_epoch, fields, flags, events)


def _event_time_label(line: bytes, line_no: int, path) -> float:
    """Calendar label of an event line (NaN when its time fields are blank)."""
    if not line[_V3_EPOCH_COLUMNS["year"][0]:_V3_SECOND[1]].strip():
        return float("nan")
    fields = calendar_fields(char_table([line], _V3_COUNT[1]), _V3_EPOCH_COLUMNS, _V3_SECOND,
                             np.array([line_no]), path)
    return float(calendar_to_gps_time_s(**{k: v[0] for k, v in fields.items()}))
