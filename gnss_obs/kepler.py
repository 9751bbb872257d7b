"""Keplerian broadcast orbits and clocks: GPS, Galileo, BeiDou (MEO/IGSO and GEO), QZSS.

One algorithm serves the four systems: the 16-parameter quasi-Keplerian ephemeris with
harmonic corrections of IS-GPS-200 (Table 20-IV), with each system's own gravitational
constant and Earth rotation rate (`gnss_obs.constants`), BeiDou's GEO rotation
(BDS-SIS-ICD §5.2.4.12: the orbit is computed in a frame tilted by -5° about x, then turned
by ``Ω_e t_k`` about z) and the satellite-clock polynomial with the relativistic eccentricity
term ``F e sqrt(A) sin E``.

Inputs are broadcast records as `read_rinex_nav` returns them (one row per satellite and
instant, columns named as there); times are GPS seconds since the GPS epoch, so that BeiDou's
14 s offset is already inside ``toe_gps_s`` / ``toc_gps_s`` and ``t - toe`` needs no week
arithmetic. The satellite position and velocity are in the ECEF frame of the system at the
same instant (WGS-84, GTRF, CGCS2000: centimetre-level apart, not distinguished here).

References
----------
IS-GPS-200N §20.3.3.3.3 (clock) and Table 20-IV (orbit, velocity); Galileo OS SIS ICD 2.0
§5.1.1-5.1.4; BDS-SIS-ICD-B1I 3.0 §5.2.4.11-12; IS-QZSS-PNT.
"""
from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from gnss_obs.constants import (
    GM_BDS,
    GM_GAL,
    GM_GPS,
    OMEGA_E_BDS,
    OMEGA_E_GAL,
    OMEGA_E_GPS,
    relativistic_constant,
)

__all__ = ["SatelliteStates", "KEPLER_SYSTEMS", "is_beidou_geo", "kepler_states",
           "eccentric_anomaly"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]
#: Broadcast records as columns: a pandas DataFrame or a dict of equal-length arrays.
Records = Mapping[str, npt.ArrayLike]

#: System letter -> (GM m^3/s^2, Earth rotation rate rad/s) of its ICD.
KEPLER_SYSTEMS: dict[str, tuple[float, float]] = {
    "G": (GM_GPS, OMEGA_E_GPS),
    "J": (GM_GPS, OMEGA_E_GPS),
    "E": (GM_GAL, OMEGA_E_GAL),
    "C": (GM_BDS, OMEGA_E_BDS),
}
#: BeiDou GEO satellites: BDS-2 PRN 1-5 and BDS-3 PRN 59-63 (BDS-SIS-ICD, RINEX 3.04 §5.11).
_BDS_GEO_PRNS = frozenset([1, 2, 3, 4, 5, 59, 60, 61, 62, 63])
#: Tilt of BeiDou's GEO orbit-computation frame about x, rad (BDS-SIS-ICD §5.2.4.12).
BDS_GEO_TILT_RAD = np.deg2rad(-5.0)


@dataclass(frozen=True)
class SatelliteStates:
    """Satellite positions, velocities and clocks from broadcast ephemerides.

    Attributes
    ----------
    r_e : ndarray, shape (N, 3)
        Satellite position (antenna phase centre as broadcast) in ECEF at the same
        instant, m.
    v_e : ndarray, shape (N, 3)
        Satellite velocity relative to ECEF, m/s.
    clock_s : ndarray, shape (N,)
        Satellite clock offset from system time, s, including the relativistic term and
        excluding any group delay (the broadcast reference signal combination).
    clock_drift_sps : ndarray, shape (N,)
        Time derivative of `clock_s`, s/s.
    relativity_s : ndarray, shape (N,)
        The relativistic part of `clock_s` (eccentricity term), s; 0 for GLONASS (inside τ).
    """

    r_e: Array
    v_e: Array
    clock_s: Array
    clock_drift_sps: Array
    relativity_s: Array


def is_beidou_geo(system: npt.ArrayLike, prn: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """True for BeiDou GEO satellites (their orbit needs the GEO rotation)."""
    system = np.asarray(system)
    prn = np.asarray(prn)
    return (system == "C") & np.isin(prn, list(_BDS_GEO_PRNS))


def eccentric_anomaly(mean_anomaly: npt.ArrayLike, e: npt.ArrayLike, *,
                      tol_rad: float = 1e-14, max_iter: int = 30) -> Array:
    """Solve Kepler's equation ``E - e sin E = M`` by Newton's method.

    Parameters
    ----------
    mean_anomaly : array_like
        Mean anomaly M, rad.
    e : array_like
        Eccentricity, 0 <= e < 1 (broadcast orbits have e < 0.03).
    tol_rad : float
        Convergence tolerance on E, rad.
    max_iter : int
        Iteration limit (Newton converges in 3-4 steps for e < 0.1).

    Returns
    -------
    ndarray
        Eccentric anomaly E, rad.
    """
    M = np.asarray(mean_anomaly, dtype=float)
    e = np.asarray(e, dtype=float)
    E = M.copy()
    for _ in range(max_iter):
        step = (E - e * np.sin(E) - M) / (1.0 - e * np.cos(E))
        E = E - step
        if np.all(np.abs(step) < tol_rad):
            break
    return E


def _columns(records: Records, names: str) -> list[Array]:
    return [np.asarray(records[n], dtype=float) for n in names.split()]


def _orbital_plane(records: Records, tk: Array, gm: Array):
    """Radius, argument of latitude, inclination and their rates; plus E and A."""
    (sqrt_a, dn, m0, e, omega, cuc, cus, crc, crs, cic, cis, i0, idot) = _columns(
        records, "sqrt_a_sqrtm delta_n_radps m0_rad e omega_rad cuc_rad cus_rad crc_m crs_m "
                 "cic_rad cis_rad i0_rad idot_radps")
    A = sqrt_a * sqrt_a
    n = np.sqrt(gm / A ** 3) + dn
    E = eccentric_anomaly(m0 + n * tk, e)
    sin_E, cos_E = np.sin(E), np.cos(E)
    E_dot = n / (1.0 - e * cos_E)
    beta = np.sqrt(1.0 - e * e)
    nu = np.arctan2(beta * sin_E, cos_E - e)
    nu_dot = E_dot * beta / (1.0 - e * cos_E)
    phi = nu + omega
    s2, c2 = np.sin(2.0 * phi), np.cos(2.0 * phi)
    u = phi + cus * s2 + cuc * c2
    r = A * (1.0 - e * cos_E) + crs * s2 + crc * c2
    i = i0 + idot * tk + cis * s2 + cic * c2
    u_dot = nu_dot * (1.0 + 2.0 * (cus * c2 - cuc * s2))
    r_dot = A * e * sin_E * E_dot + 2.0 * nu_dot * (crs * c2 - crc * s2)
    i_dot = idot + 2.0 * nu_dot * (cis * c2 - cic * s2)
    return r, u, i, r_dot, u_dot, i_dot, E, E_dot, A


def _rotate_to_frame(r, u, i, r_dot, u_dot, i_dot, Omega, Omega_dot):
    """Position and velocity from orbital-plane quantities and the node longitude Ω.

    Velocity by the chain rule of ``x = x' cosΩ - y' cos i sinΩ`` etc. (IS-GPS-200N
    Table 20-IV, velocity part).
    """
    xp, yp = r * np.cos(u), r * np.sin(u)
    xp_dot = r_dot * np.cos(u) - yp * u_dot
    yp_dot = r_dot * np.sin(u) + xp * u_dot
    cO, sO, ci, si = np.cos(Omega), np.sin(Omega), np.cos(i), np.sin(i)
    pos = np.stack([xp * cO - yp * ci * sO, xp * sO + yp * ci * cO, yp * si], axis=-1)
    vel = np.stack([
        xp_dot * cO - yp_dot * ci * sO + yp * si * sO * i_dot - pos[:, 1] * Omega_dot,
        xp_dot * sO + yp_dot * ci * cO - yp * si * cO * i_dot + pos[:, 0] * Omega_dot,
        yp_dot * si + yp * ci * i_dot], axis=-1)
    return pos, vel


def _geo_to_ecef(pos_g: Array, vel_g: Array, tk: Array, omega_e: Array) -> tuple[Array, Array]:
    """BeiDou GEO: ``r = R_z(Ω_e t_k) R_x(-5°) r_g`` (BDS-SIS-ICD §5.2.4.12), and its rate."""
    cx, sx = np.cos(BDS_GEO_TILT_RAD), np.sin(BDS_GEO_TILT_RAD)
    R_x = np.array([[1.0, 0.0, 0.0], [0.0, cx, sx], [0.0, -sx, cx]])
    a = omega_e * tk
    ca, sa = np.cos(a), np.sin(a)
    zero, one = np.zeros_like(a), np.ones_like(a)
    R_z = np.stack([np.stack([ca, sa, zero], -1), np.stack([-sa, ca, zero], -1),
                    np.stack([zero, zero, one], -1)], axis=-2)
    dR_z = omega_e[:, None, None] * np.stack(
        [np.stack([-sa, ca, zero], -1), np.stack([-ca, -sa, zero], -1),
         np.stack([zero, zero, zero], -1)], axis=-2)
    p = pos_g @ R_x.T
    v = vel_g @ R_x.T
    r_e = np.einsum("nij,nj->ni", R_z, p)
    v_e = np.einsum("nij,nj->ni", R_z, v) + np.einsum("nij,nj->ni", dR_z, p)
    return r_e, v_e


def kepler_states(records: Records, t_gps_s: npt.ArrayLike) -> SatelliteStates:
    """Satellite states from Keplerian broadcast records, one record per requested time.

    Parameters
    ----------
    records : Records, N rows
        Broadcast records of systems G, E, C or J (columns of `read_rinex_nav`: ``sv``,
        ``prn``, ``toe_gps_s``, ``toc_gps_s``, ``toe_sow``, ``af0_s`` ... ``idot_radps``);
        row k is used at time ``t_gps_s[k]``.
    t_gps_s : array_like, shape (N,)
        GPS time of each evaluation (the signal transmission time), s since the GPS epoch.

    Returns
    -------
    SatelliteStates
        With N rows. The clock excludes group delays (see `ephemeris.group_delay_s`).

    Raises
    ------
    ValueError
        If a record belongs to another system or the lengths differ.
    """
    t = np.asarray(t_gps_s, dtype=float)
    system = np.asarray(records["sv"]).astype(str).astype("U1")
    if t.shape != system.shape:
        raise ValueError(f"t_gps_s must have shape {system.shape}, got {t.shape}")
    letters, which = np.unique(system, return_inverse=True)   # per system, not per row
    unknown = set(letters) - set(KEPLER_SYSTEMS)
    if unknown:
        raise ValueError(f"no Keplerian ephemeris for systems {sorted(unknown)}")
    gm, omega_e, F = _system_constants(letters, which)
    geo = is_beidou_geo(system, np.asarray(records["prn"]))
    tk = t - np.asarray(records["toe_gps_s"], dtype=float)
    r, u, i, r_dot, u_dot, i_dot, E, E_dot, A = _orbital_plane(records, tk, gm)
    omega0, omega_dot, toe_sow = _columns(records, "omega0_rad omega_dot_radps toe_sow")
    # Node longitude in ECEF (MEO/IGSO) or in the inertial-like frame of the GEO algorithm.
    rate = np.where(geo, omega_dot, omega_dot - omega_e)
    Omega = omega0 + rate * tk - omega_e * toe_sow
    r_e, v_e = _rotate_to_frame(r, u, i, r_dot, u_dot, i_dot, Omega, rate)
    if np.any(geo):
        r_e[geo], v_e[geo] = _geo_to_ecef(r_e[geo], v_e[geo], tk[geo], omega_e[geo])
    clock_s, drift_sps, rel_s = _clock(records, t, E, E_dot, A, F)
    return SatelliteStates(r_e, v_e, clock_s, drift_sps, rel_s)


def _system_constants(letters: np.ndarray, which: np.ndarray) -> tuple[Array, Array, Array]:
    """GM (m³/s²), Earth rate (rad/s) and relativistic constant F (s/m^½) of each row's
    system (`KEPLER_SYSTEMS`, `gnss_obs.constants.relativistic_constant`): computed once per
    system letter of `letters` and spread to the rows by the indices `which`."""
    gm = np.array([KEPLER_SYSTEMS[s][0] for s in letters], dtype=float)
    omega_e = np.array([KEPLER_SYSTEMS[s][1] for s in letters], dtype=float)
    F = np.array([relativistic_constant(g) for g in gm], dtype=float)
    return gm[which], omega_e[which], F[which]


def _clock(records: Records, t: Array, E: Array, E_dot: Array, A: Array, F: Array):
    """Clock polynomial + relativistic term (IS-GPS-200N §20.3.3.3.3.1) and its rate
    (`F`: the relativistic constant of each row's system)."""
    af0, af1, af2, e = _columns(records, "af0_s af1_sps af2_sps2 e")
    dt = t - np.asarray(records["toc_gps_s"], dtype=float)
    rel = F * e * np.sqrt(A) * np.sin(E)
    rel_rate = F * e * np.sqrt(A) * np.cos(E) * E_dot
    clock = af0 + af1 * dt + af2 * dt * dt + rel
    drift = af1 + 2.0 * af2 * dt + rel_rate
    return clock, drift, rel
