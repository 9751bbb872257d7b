"""Field order of RINEX navigation records, per system (RINEX 3.04 Tables A6–A17, 2.11 A4).

A record is an epoch line (satellite, clock epoch ``toc``, 3 values) and continuation
("broadcast orbit") lines of 4 values each, in D19.12 format. Each layout below lists the
values in file order; ``None`` marks a spare or a value we do not keep. Unit conversions
from the file (GLONASS and SBAS positions in km) are in `KM_FIELDS`.
"""
from __future__ import annotations

__all__ = ["KEPLER_FIELDS", "LAYOUTS", "KM_FIELDS", "INT_FIELDS", "TIME_SCALE",
           "continuation_lines"]

_CLOCK = ["af0_s", "af1_sps", "af2_sps2"]
_ORBIT = ["crs_m", "delta_n_radps", "m0_rad",
          "cuc_rad", "e", "cus_rad", "sqrt_a_sqrtm",
          "toe_sow", "cic_rad", "omega0_rad", "cis_rad",
          "i0_rad", "crc_m", "omega_rad", "omega_dot_radps",
          "idot_radps"]


def _kepler(issue: str, line5: list, line6: list, line7: list) -> list:
    """Clock, issue of data, the 16 orbit elements, then broadcast orbits 5–7."""
    return _CLOCK + [issue] + _ORBIT + line5 + line6 + line7


#: Values of a Keplerian record (G, E, C, J, I), file order.
LAYOUTS: dict[str, list[str | None]] = {
    "G": _kepler("iode", [None, "week", None], ["sv_accuracy_m", "health", "tgd_s", "iodc"],
                 ["transmission_time_sow", "fit_interval_h", None, None]),
    "J": _kepler("iode", [None, "week", None], ["sv_accuracy_m", "health", "tgd_s", "iodc"],
                 ["transmission_time_sow", "fit_interval_h", None, None]),
    "E": _kepler("iode", ["data_sources", "week", None],
                 ["sv_accuracy_m", "health", "bgd_e5a_e1_s", "bgd_e5b_e1_s"],
                 ["transmission_time_sow", None, None, None]),
    "C": _kepler("aode", [None, "week", None], ["sv_accuracy_m", "health", "tgd1_s", "tgd2_s"],
                 ["transmission_time_sow", "aodc", None, None]),
    "I": _kepler("iode", [None, "week", None], ["sv_accuracy_m", "health", "tgd_s", None],
                 ["transmission_time_sow", None, None, None]),
    "R": ["clock_bias_s", "gamma_n", "message_frame_time_s",
          "x_m", "vx_mps", "ax_mps2", "health",
          "y_m", "vy_mps", "ay_mps2", "freq_channel",
          "z_m", "vz_mps", "az_mps2", "age_days"],
    "S": ["af0_s", "af1_sps", "message_frame_time_s",
          "x_m", "vx_mps", "ax_mps2", "health",
          "y_m", "vy_mps", "ay_mps2", "ura",
          "z_m", "vz_mps", "az_mps2", "iodn"],
}
#: Columns every Keplerian frame has (NaN where a system does not broadcast the value).
KEPLER_FIELDS = (_CLOCK + ["iode"] + _ORBIT
                 + ["week", "sv_accuracy_m", "health", "tgd_s", "iodc",
                    "transmission_time_sow", "fit_interval_h"])
#: Fields given in km, km/s, km/s² by RINEX (GLONASS, SBAS).
KM_FIELDS = ("x_m", "y_m", "z_m", "vx_mps", "vy_mps", "vz_mps", "ax_mps2", "ay_mps2", "az_mps2")
#: Fields stored as integers (a blank one is an error).
INT_FIELDS = ("week", "data_sources", "freq_channel")
#: Time scale of the record's clock epoch, per system (RINEX 3.04 §6.6).
TIME_SCALE = {"G": "GPS", "E": "GAL", "C": "BDT", "J": "QZS", "I": "IRN", "R": "UTC",
              "S": "GPS"}
#: Extra GLONASS broadcast-orbit line from RINEX 3.05 on (status flags, dTau, URAI, health).
_GLONASS_EXTRA_LINE_VERSION = 3.05


def continuation_lines(system: str, version: float) -> int:
    """Number of broadcast-orbit lines after the epoch line of a record."""
    if system in ("R", "S"):
        if system == "R" and version >= _GLONASS_EXTRA_LINE_VERSION - 1e-9:
            return 4
        return 3
    return 7
