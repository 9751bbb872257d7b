"""Broadcast ephemerides: record selection, satellite states for any system, group delays.

The one entry point for "where is satellite X at GPS time t and what is its clock":

1. `select_ephemeris` picks, per (satellite, time) request, the healthy record whose
   reference time (``toe`` for Keplerian systems, ``t_b`` for GLONASS) is nearest to the
   time and within the system's validity (`MAX_AGE_S`; GPS/QZSS use half the record's fit
   interval). Records issued *after* the time are allowed: in post-processing a
   satellite's only valid record may be one transmitted later (see the data README).
   Galileo carries two navigation messages whose clocks refer to different signal pairs:
   I/NAV (E1/E5b, data-source bit 9) and F/NAV (E1/E5a, bit 8); `galileo_message` picks one.
2. `satellite_states` evaluates the selected records (`gnss_obs.kepler` for G/E/C/J,
   `gnss_obs.glonass` for R).
3. `group_delay_s` gives the broadcast group delay of a signal: the satellite clock for a
   single-frequency user of band k is ``clock_s - group_delay_s(k)`` (IS-GPS-200N
   §20.3.3.3.3.2, Galileo OS SIS ICD §5.1.5, BDS-SIS-ICD §5.2.4.10).

References
----------
IS-GPS-200N; Galileo OS SIS ICD 2.0; BDS-SIS-ICD-B1I 3.0; GLONASS ICD 5.1; RINEX 3.04
(Galileo data-source bits, Table A8).
"""
from __future__ import annotations

import logging

import numpy as np
import numpy.typing as npt
import pandas as pd

from gnss_obs.constants import carrier_frequency_hz
from gnss_obs.glonass import glonass_states
from gnss_obs.kepler import KEPLER_SYSTEMS, Records, SatelliteStates, kepler_states

__all__ = ["MAX_AGE_S", "GALILEO_MESSAGES", "select_ephemeris", "take_rows",
           "satellite_states", "group_delay_s"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

_HOUR_S = 3600.0
#: Largest |t - reference time| for which a record is used, s, per system. GPS/QZSS: the
#: 4 h curve fit -> ±2 h (or half the record's fit interval). Galileo records (refreshed
#: every 10 min) and BeiDou records (hourly) are fitted for short use: against the CODE
#: final orbits of 2020-11-29 Galileo errors grow from ~1 m within 1 h to 9 m at 1-1.5 h,
#: 18 m at 1.5-2 h and 30-100 m beyond, so both take ±2 h. GLONASS t_b every 30 min ->
#: ±15 min, with margin ±30 min.
MAX_AGE_S = {"G": 2 * _HOUR_S, "J": 2 * _HOUR_S, "E": 2 * _HOUR_S, "C": 2 * _HOUR_S,
             "R": 0.5 * _HOUR_S}
#: Galileo navigation message -> data-source bit saying which signal pair its clock serves
#: (RINEX 3.04 Table A8: bit 8 = af0..af2 for E5a,E1 (F/NAV); bit 9 = E5b,E1 (I/NAV)).
GALILEO_MESSAGES = {"fnav": 1 << 8, "inav": 1 << 9}
#: Galileo group delay column and the band it pairs with E1 in each message.
_GAL_BGD = {"fnav": ("bgd_e5a_e1_s", 5), "inav": ("bgd_e5b_e1_s", 7)}


def _usable(records: pd.DataFrame, system: str, galileo_message: str,
            healthy_only: bool) -> npt.NDArray[np.bool_]:
    ok = np.ones(len(records), dtype=bool)
    if healthy_only:
        ok &= records["health"].to_numpy(dtype=float) == 0
    if system == "E":
        sources = records["data_sources"].to_numpy(dtype=float).astype(np.int64)
        ok &= (sources & GALILEO_MESSAGES[galileo_message]) != 0
    return ok


def _reference_time(records: pd.DataFrame, system: str) -> Array:
    return records["toc_gps_s" if system == "R" else "toe_gps_s"].to_numpy(dtype=float)


def _max_age(records: pd.DataFrame, system: str) -> Array:
    age = np.full(len(records), MAX_AGE_S[system])
    if system in ("G", "J") and "fit_interval_h" in records:
        fit_h = records["fit_interval_h"].to_numpy(dtype=float)
        age = np.where(np.isfinite(fit_h) & (fit_h > 0), 0.5 * fit_h * _HOUR_S, age)
    return age


def _select_system(records: pd.DataFrame, system: str, sv: np.ndarray, t: Array,
                   galileo_message: str, healthy_only: bool) -> np.ndarray:
    """Row index into `records` (-1 when none) for each request of one system."""
    chosen = np.full(len(sv), -1, dtype=np.int64)
    usable = _usable(records, system, galileo_message, healthy_only)
    ref = _reference_time(records, system)
    age = _max_age(records, system)
    rec_sv = records["sv"].to_numpy()
    for name in np.unique(sv):
        req = np.flatnonzero(sv == name)
        cand = np.flatnonzero((rec_sv == name) & usable)
        if cand.size == 0:
            continue
        dist = np.abs(t[req, None] - ref[None, cand])
        dist = np.where(dist <= age[None, cand], dist, np.inf)
        best = np.argmin(dist, axis=1)
        found = np.isfinite(dist[np.arange(req.size), best])
        chosen[req[found]] = cand[best[found]]
    return chosen


def select_ephemeris(records: dict[str, pd.DataFrame], sv: npt.ArrayLike,
                     t_gps_s: npt.ArrayLike, *, galileo_message: str = "inav",
                     healthy_only: bool = True) -> pd.DataFrame:
    """The broadcast record to use for each (satellite, time) request.

    Parameters
    ----------
    records : dict of str to pandas.DataFrame
        `RinexNav.records`: system letter -> records of that system.
    sv : array_like of str, shape (N,)
        Satellites (``"G05"``).
    t_gps_s : array_like, shape (N,)
        Times, s since the GPS epoch (any instant within a few minutes of use: the choice
        does not depend on the exact transmission time).
    galileo_message : {"inav", "fnav"}
        Galileo message whose clock to use (E1/E5b or E1/E5a reference).
    healthy_only : bool
        Skip records whose health flag is not 0.

    Returns
    -------
    pandas.DataFrame, N rows in request order
        The chosen records' columns (union over systems), ``sv`` as requested, ``system``,
        and ``ephemeris_ok`` (False where no record is valid: the other columns are NaN).
    """
    if galileo_message not in GALILEO_MESSAGES:
        raise ValueError(f"galileo_message must be one of {sorted(GALILEO_MESSAGES)}, "
                         f"got {galileo_message!r}")
    sv = np.asarray(sv).astype(str)
    t = np.broadcast_to(np.asarray(t_gps_s, dtype=float), sv.shape)
    # each request's system letter, ``s[:1]`` of each (the first character, as Python
    # strings), without a Python loop over the requests (~10 ms for a simulated trip's
    # 32 000)
    system = sv.astype("U1").astype(object)
    parts = []
    for letter in np.unique(system):
        req = np.flatnonzero(system == letter)
        recs = records.get(letter)
        if recs is None or len(recs) == 0 or (letter not in KEPLER_SYSTEMS and letter != "R"):
            parts.append(pd.DataFrame(index=req))
            continue
        recs = recs.reset_index(drop=True)
        rows = _select_system(recs, letter, sv[req], t[req], galileo_message, healthy_only)
        picked = recs.reindex(rows).set_axis(req)  # -1 -> a NaN row
        parts.append(picked)
    out = pd.concat(parts).sort_index() if parts else pd.DataFrame(index=np.arange(0))
    out = out.reindex(np.arange(len(sv)))
    ok = out["toc_gps_s"].notna().to_numpy() if "toc_gps_s" in out else np.zeros(len(sv), bool)
    out["sv"] = sv
    out["system"] = system
    out["ephemeris_ok"] = ok
    return out.reset_index(drop=True)


def take_rows(selected: Records, index: npt.ArrayLike) -> dict[str, np.ndarray]:
    """Rows `index` (integer or boolean) of a column mapping, as a dict of arrays."""
    return {name: np.asarray(values)[index] for name, values in selected.items()}


def satellite_states(selected: Records, t_gps_s: npt.ArrayLike) -> SatelliteStates:
    """Satellite states of selected records at the given times (NaN where no record).

    Parameters
    ----------
    selected : Records, N rows
        Output of `select_ephemeris` (a DataFrame, or its columns as a dict of arrays as
        `take_rows` gives: the fast form inside per-epoch loops).
    t_gps_s : array_like, shape (N,)
        Evaluation times (signal transmission times), s since the GPS epoch.

    Returns
    -------
    SatelliteStates
        N rows, ECEF of the evaluation instant; NaN rows where ``ephemeris_ok`` is False.
    """
    ok = np.asarray(selected["ephemeris_ok"], dtype=bool)
    n = ok.size
    t = np.broadcast_to(np.asarray(t_gps_s, dtype=float), (n,))
    r_e, v_e = np.full((n, 3), np.nan), np.full((n, 3), np.nan)
    clock, drift, rel = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    system = np.asarray(selected["system"])
    for mask, fn in ((ok & (system != "R"), kepler_states), (ok & (system == "R"), glonass_states)):
        if np.any(mask):
            s = fn(take_rows(selected, mask), t[mask])
            r_e[mask], v_e[mask] = s.r_e, s.v_e
            clock[mask], drift[mask], rel[mask] = s.clock_s, s.clock_drift_sps, s.relativity_s
    return SatelliteStates(r_e, v_e, clock, drift, rel)


def _gamma(system: str, band: int, reference_band: int) -> float:
    """``(f_ref / f_band)²``: how a group delay defined on the reference band scales."""
    return (carrier_frequency_hz(system, reference_band) / carrier_frequency_hz(system, band)) ** 2


def group_delay_s(selected: Records, band: npt.ArrayLike, *,
                  galileo_message: str = "inav") -> Array:
    """Broadcast group delay of the signal in `band`, s (NaN when the message has none).

    The satellite clock a single-frequency pseudorange on `band` needs is
    ``clock_s - group_delay_s``:

    * GPS/QZSS (LNAV): band 1 ``T_GD``, band 2 ``γ12 T_GD`` with ``γ12 = (f1/f2)²``
      (IS-GPS-200N §20.3.3.3.3.2); band 5 needs the CNAV ISC, absent here -> NaN;
    * Galileo: band 1 ``BGD(E1,E5x)``, and band 5 (F/NAV) or 7 (I/NAV)
      ``(f1/f5x)² BGD(E1,E5x)`` for the message's pair (OS SIS ICD §5.1.5);
    * BeiDou D1/D2: B1I (band 2) ``T_GD1``, B2I (band 7) ``T_GD2``, B3I (band 6) 0;
      B1C/B2a need the CNAV ISC -> NaN;
    * GLONASS: 0 (its clock refers to the L1/L2 code pair of the broadcast; the
      inter-frequency ``Δτ_n`` is not in RINEX 3.04).

    Parameters
    ----------
    selected : Records, N rows
        Output of `select_ephemeris` (with the same `galileo_message`), or `take_rows` of it.
    band : array_like of int, shape (N,) or scalar
        RINEX band number of each row's signal.
    galileo_message : {"inav", "fnav"}

    Returns
    -------
    ndarray, shape (N,)
        Group delay, s.
    """
    system = np.asarray(selected["system"])
    n = system.size
    band = np.broadcast_to(np.asarray(band, dtype=np.int64), (n,))
    out = np.full(n, np.nan)

    def col(name: str) -> Array:
        return np.asarray(selected[name], dtype=float) if name in selected else np.full(n, np.nan)

    for s in ("G", "J"):
        tgd = col("tgd_s")
        out = np.where((system == s) & (band == 1), tgd, out)
        out = np.where((system == s) & (band == 2), _gamma(s, 2, 1) * tgd, out)
    bgd_name, pair_band = _GAL_BGD[galileo_message]
    bgd = col(bgd_name)
    out = np.where((system == "E") & (band == 1), bgd, out)
    out = np.where((system == "E") & (band == pair_band), _gamma("E", pair_band, 1) * bgd, out)
    out = np.where((system == "C") & (band == 2), col("tgd1_s"), out)
    out = np.where((system == "C") & (band == 7), col("tgd2_s"), out)
    out = np.where((system == "C") & (band == 6), 0.0, out)
    out = np.where(system == "R", 0.0, out)
    return out
