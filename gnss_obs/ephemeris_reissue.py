"""Broadcast records re-issued beyond their day: a synthetic constellation for long trips.

A broadcast Keplerian record is valid for a few hours around its reference time
(`gnss_obs.ephemeris.MAX_AGE_S`), so a navigation file of two hours cannot serve a
ten-hour simulated trip. `reissue_ephemerides` extends a file: for every satellite it
takes the last (and first) healthy record and issues copies every ``interval_s`` whose
reference times move by ``Δt = k · interval_s`` while the **orbit and clock they describe
stay exactly those of the original record** (IS-GPS-200N Table 20-IV and §20.3.3.3.3.1
evaluated at the same instant give the same state):

* ``toe, toc += Δt``  (``toe_sow`` and ``week`` rolled over at the week boundary);
* ``M0 += n Δt``, ``n = sqrt(GM / A³) + Δn``  (mean anomaly at the new ``toe``);
* ``Ω0 += Ω̇ Δt − Ω_e · WEEK_S · (weeks rolled over)``: the node longitude is
  ``Ω = Ω0 + (Ω̇ − Ω_e) t_k − Ω_e toe_sow``, so this keeps ``Ω(t)``;
* ``i0 += IDOT Δt``;
* ``af0 += af1 Δt + af2 Δt²``, ``af1 += 2 af2 Δt``  (the clock polynomial about ``toc``);
* everything else (``√A, e, ω, Δn``, harmonic corrections, ``T_GD``, health, issue of data
  numbers) unchanged; ``transmission_time_sow`` keeps its offset to ``toe``.

Galileo records are re-issued per navigation message (I/NAV and F/NAV clocks refer to
different signal pairs, `gnss_obs.ephemeris.GALILEO_MESSAGES`).

The result is a two-body-plus-broadcast-corrections extrapolation of each orbit: not the
real sky of the later hours (perturbations not in the broadcast model accumulate), but a
self-consistent synthetic constellation with realistic geometry. A simulator and a filter
that both use the extended file see the same satellites. Systems G, J, E and C (BeiDou
GEO records, whose frame turns with ``t_k``, are not re-issued).
"""
from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np
import pandas as pd

from gnss_obs.constants import WEEK_S
from gnss_obs.errors import GnssError
from gnss_obs.kepler import KEPLER_SYSTEMS, is_beidou_geo
from gnss_obs.rinex_nav import RinexNav

__all__ = ["reissue_ephemerides", "propagate_records", "DEFAULT_REISSUE_INTERVAL_S"]

log = logging.getLogger(__name__)

#: Interval between re-issued records, s: GPS issues a record every 2 h, each used within
#: ±2 h of its ``toe`` (`gnss_obs.ephemeris.MAX_AGE_S`), so every instant has one within 1 h.
DEFAULT_REISSUE_INTERVAL_S = 7200.0


def propagate_records(records: pd.DataFrame, dt_s: float, system: str) -> pd.DataFrame:
    """Records of one Keplerian system with reference times moved by `dt_s` (module docstring).

    Parameters
    ----------
    records : pandas.DataFrame
        Records of `system` as `gnss_obs.read_rinex_nav` returns them.
    dt_s : float
        Shift of ``toe``/``toc``, s (either sign).
    system : str
        System letter, one of ``G J E C``.

    Returns
    -------
    pandas.DataFrame
        A copy with the shifted elements; evaluated at any time it gives the same satellite
        position, velocity and clock as `records`.

    Raises
    ------
    GnssError
        For a system without Keplerian records, or BeiDou GEO records.
    """
    if system not in KEPLER_SYSTEMS:
        raise GnssError(f"cannot re-issue records of system {system!r}: not Keplerian")
    if system == "C" and np.any(is_beidou_geo(np.full(len(records), "C"), records["prn"])):
        raise GnssError("BeiDou GEO records cannot be re-issued (their frame turns with t_k)")
    gm, omega_e = KEPLER_SYSTEMS[system]
    out = records.copy()
    a = out["sqrt_a_sqrtm"].to_numpy(dtype=float) ** 2
    n = np.sqrt(gm / a ** 3) + out["delta_n_radps"].to_numpy(dtype=float)
    sow = out["toe_sow"].to_numpy(dtype=float) + dt_s
    weeks = np.floor(sow / WEEK_S)
    out["toe_sow"] = sow - weeks * WEEK_S
    out["week"] = (out["week"].to_numpy() + weeks).astype(records["week"].dtype)
    out["toe_gps_s"] = out["toe_gps_s"] + dt_s
    out["toc_gps_s"] = out["toc_gps_s"] + dt_s
    out["m0_rad"] = _wrap(out["m0_rad"].to_numpy(dtype=float) + n * dt_s)
    out["omega0_rad"] = _wrap(out["omega0_rad"].to_numpy(dtype=float)
                              + out["omega_dot_radps"].to_numpy(dtype=float) * dt_s
                              - omega_e * WEEK_S * weeks)
    out["i0_rad"] = out["i0_rad"] + out["idot_radps"] * dt_s
    af1, af2 = out["af1_sps"].to_numpy(dtype=float), out["af2_sps2"].to_numpy(dtype=float)
    out["af0_s"] = out["af0_s"] + af1 * dt_s + af2 * dt_s * dt_s
    out["af1_sps"] = af1 + 2.0 * af2 * dt_s
    if "transmission_time_sow" in out:
        out["transmission_time_sow"] = np.mod(out["transmission_time_sow"] + dt_s, WEEK_S)
    return out


def _wrap(angle: np.ndarray) -> np.ndarray:
    """Angle in [-π, π), rad (sin and cos unchanged)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def reissue_ephemerides(nav: RinexNav, *, end_gps_time_s: float,
                        start_gps_time_s: float | None = None,
                        interval_s: float = DEFAULT_REISSUE_INTERVAL_S,
                        systems: str = "GJEC") -> RinexNav:
    """`nav` with records re-issued every `interval_s` out to `end_gps_time_s`.

    Parameters
    ----------
    nav : RinexNav
        A navigation file (`gnss_obs.read_rinex_nav`).
    end_gps_time_s : float
        Last time that must be covered, s since the GPS epoch: each satellite's latest
        healthy record is re-issued at ``toe + k·interval_s`` until a ``toe`` reaches it.
    start_gps_time_s : float, optional
        First time that must be covered; the earliest record is re-issued backwards
        likewise (default: no earlier records).
    interval_s : float
        Spacing of the re-issued reference times, s (> 0; at most twice the selection's
        validity, `gnss_obs.ephemeris.MAX_AGE_S`, for gap-free coverage).
    systems : str
        Systems to extend (letters of ``GJEC`` present in `nav`); others are kept as they
        are. BeiDou GEO satellites are left out.

    Returns
    -------
    RinexNav
        The header and all original records, plus the re-issued ones, sorted by
        (``sv``, ``toc_gps_s``).

    Raises
    ------
    GnssError
        For a bad interval or a system that cannot be re-issued.
    """
    if not (math.isfinite(interval_s) and interval_s > 0):
        raise GnssError(f"interval_s must be finite and > 0, got {interval_s!r}")
    records = dict(nav.records)
    for system in systems:
        recs = records.get(system)
        if recs is None or len(recs) == 0:
            continue
        if system not in KEPLER_SYSTEMS:
            raise GnssError(f"cannot re-issue records of system {system!r}: not Keplerian")
        usable = recs[recs["health"].to_numpy(dtype=float) == 0]
        if system == "C":
            geo = is_beidou_geo(np.full(len(usable), "C"), usable["prn"])
            usable = usable[~geo]
        new = [recs] + _reissued(usable, system, end_gps_time_s, start_gps_time_s,
                                 interval_s)
        merged = pd.concat(new, ignore_index=True)
        records[system] = merged.sort_values(["sv", "toc_gps_s"], kind="stable",
                                             ignore_index=True)
        log.debug("system %s: %d records re-issued", system, len(merged) - len(recs))
    return replace(nav, records=records)


def _reissued(usable: pd.DataFrame, system: str, end_s: float, start_s: float | None,
              interval_s: float) -> list[pd.DataFrame]:
    """Copies of each satellite's last record forward (first record backward); per
    navigation message for Galileo (I/NAV and F/NAV records serve different signals)."""
    if len(usable) == 0:
        return []
    toe = usable["toe_gps_s"].to_numpy(dtype=float)
    order = np.argsort(toe, kind="stable")
    keys = ["sv", "nav_type"] if "nav_type" in usable else ["sv"]
    by_sv = usable.iloc[order].groupby(keys, sort=True)
    last, first = by_sv.tail(1), by_sv.head(1)
    out = []
    k_fwd = int(math.ceil(max(end_s - float(last["toe_gps_s"].min()), 0.0) / interval_s))
    for k in range(1, k_fwd + 1):
        rows = last[last["toe_gps_s"] + (k - 1) * interval_s < end_s]
        out.append(propagate_records(rows, k * interval_s, system))
    if start_s is not None:
        k_back = int(math.ceil(max(float(first["toe_gps_s"].max()) - start_s, 0.0)
                               / interval_s))
        for k in range(1, k_back + 1):
            rows = first[first["toe_gps_s"] - (k - 1) * interval_s > start_s]
            out.append(propagate_records(rows, -k * interval_s, system))
    return [o for o in out if len(o)]
