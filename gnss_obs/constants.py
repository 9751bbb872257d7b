"""GNSS constants: speed of light, system frequencies, each ICD's Earth constants.

The single owner of GNSS constants (STYLE.md §2.2). Constants that differ between
documents carry different names: the GPS ICD's Earth rotation rate ``OMEGA_E_GPS``
(7.2921151467e-5 rad/s) is not WGS-84's ``trackmodel.earth.OMEGA_E_WGS84``
(7.292115e-5 rad/s), and each system's orbit computation must use its own.

References
----------
IS-GPS-200N (GPS), Galileo OS SIS ICD 2.0, BDS-SIS-ICD-B1I 3.0, GLONASS ICD 5.1,
RINEX 3.04 (frequency band numbers).
"""
from __future__ import annotations

import math

__all__ = [
    "SPEED_OF_LIGHT_MPS", "WEEK_S", "DAY_S", "GM_GPS", "OMEGA_E_GPS", "GM_GAL", "OMEGA_E_GAL",
    "GM_BDS", "OMEGA_E_BDS", "GM_GLO", "OMEGA_E_GLO", "A_GLO_M", "J2_GLO", "BDT_MINUS_GPST_S",
    "relativistic_constant", "carrier_frequency_hz", "wavelength_m",
    "SYSTEMS", "SYSTEM_NAMES", "FREQUENCY_HZ", "BDT_WEEK0_GPS_WEEK",
]

#: Speed of light in vacuum, m/s (exact).
SPEED_OF_LIGHT_MPS = 299_792_458.0
#: Seconds in a GNSS week and in a day.
WEEK_S = 604_800
DAY_S = 86_400

#: GPS (IS-GPS-200): gravitational constant m^3/s^2, Earth rotation rate rad/s.
GM_GPS = 3.986005e14
OMEGA_E_GPS = 7.2921151467e-5
#: Galileo (OS SIS ICD §5.1.1).
GM_GAL = 3.986004418e14
OMEGA_E_GAL = 7.2921151467e-5
#: BeiDou (BDS-SIS-ICD, CGCS2000).
GM_BDS = 3.986004418e14
OMEGA_E_BDS = 7.292115e-5
#: GLONASS (ICD 5.1, PZ-90.11): GM, rotation rate, semi-major axis (m), second zonal harmonic.
GM_GLO = 3.986004418e14
OMEGA_E_GLO = 7.292115e-5
A_GLO_M = 6_378_136.0
J2_GLO = 1.08262575e-3

#: BeiDou time (BDT) runs 14 s behind GPS time: BDT = GPST - 14 s.
BDT_MINUS_GPST_S = -14.0
#: BeiDou week 0 began 2006-01-01 00:00:00 BDT, in GPS week 1356 (BDS-SIS-ICD §5.1.2.2).
BDT_WEEK0_GPS_WEEK = 1356

#: RINEX system letters: GPS, GLONASS, Galileo, BeiDou, QZSS, NavIC/IRNSS, SBAS.
SYSTEMS = ("G", "R", "E", "C", "J", "I", "S")
#: System letter -> name, for messages.
SYSTEM_NAMES = {"G": "GPS", "R": "GLONASS", "E": "Galileo", "C": "BeiDou", "J": "QZSS",
                "I": "NavIC", "S": "SBAS"}

_MHZ = 1e6
#: Carrier frequency (Hz) by system letter and RINEX 3 band number (the digit of e.g. ``C1C``).
#: GLONASS FDMA bands 1 and 2 are absent here: they depend on the channel (`carrier_frequency_hz`).
FREQUENCY_HZ: dict[str, dict[int, float]] = {
    "G": {1: 1575.42 * _MHZ, 2: 1227.60 * _MHZ, 5: 1176.45 * _MHZ},
    "R": {4: 1600.995 * _MHZ, 6: 1248.06 * _MHZ, 3: 1202.025 * _MHZ},
    "E": {1: 1575.42 * _MHZ, 5: 1176.45 * _MHZ, 7: 1207.14 * _MHZ, 8: 1191.795 * _MHZ,
          6: 1278.75 * _MHZ},
    "C": {1: 1575.42 * _MHZ, 2: 1561.098 * _MHZ, 5: 1176.45 * _MHZ, 7: 1207.14 * _MHZ,
          8: 1191.795 * _MHZ, 6: 1268.52 * _MHZ},
    "J": {1: 1575.42 * _MHZ, 2: 1227.60 * _MHZ, 5: 1176.45 * _MHZ, 6: 1278.75 * _MHZ},
    "I": {5: 1176.45 * _MHZ, 9: 2492.028 * _MHZ},
    "S": {1: 1575.42 * _MHZ, 5: 1176.45 * _MHZ},
}
#: GLONASS FDMA: f = base + k * step for channel number k in [-7, 6].
_GLO_FDMA_HZ = {1: (1602.0 * _MHZ, 0.5625 * _MHZ), 2: (1246.0 * _MHZ, 0.4375 * _MHZ)}


def carrier_frequency_hz(system: str, band: int, glonass_channel: int | None = None) -> float:
    """Carrier frequency of a signal.

    Parameters
    ----------
    system : str
        RINEX system letter (``"G"``, ``"R"``, ``"E"``, ``"C"``, ``"J"``, ``"I"``, ``"S"``).
    band : int
        RINEX 3 band number (``1`` for ``C1C``, ``5`` for ``C5Q``...).
    glonass_channel : int, optional
        GLONASS frequency channel number k (required for GLONASS bands 1 and 2).

    Returns
    -------
    float
        Frequency, Hz.

    Raises
    ------
    KeyError
        For a system/band pair that does not exist, or a missing GLONASS channel.
    """
    if system == "R" and band in _GLO_FDMA_HZ:
        if glonass_channel is None:
            raise KeyError(f"GLONASS band {band} needs the frequency channel number")
        base, step = _GLO_FDMA_HZ[band]
        return base + glonass_channel * step
    try:
        return FREQUENCY_HZ[system][band]
    except KeyError:
        raise KeyError(f"no carrier frequency for system {system!r} band {band}") from None


def wavelength_m(system: str, band: int, glonass_channel: int | None = None) -> float:
    """Carrier wavelength ``c / f``, m (Doppler in Hz -> range rate: ``-wavelength * D``)."""
    return SPEED_OF_LIGHT_MPS / carrier_frequency_hz(system, band, glonass_channel)


def relativistic_constant(gm_m3ps2: float) -> float:
    """``F = -2 sqrt(GM) / c²`` (s/m^½) of the eccentricity clock correction ``F e sqrt(A) sin E``.

    GPS: -4.442807633e-10 (IS-GPS-200 §20.3.3.3.3.1).
    """
    return -2.0 * math.sqrt(gm_m3ps2) / SPEED_OF_LIGHT_MPS ** 2
