"""gnss_obs — GNSS observations and their models.

Owns: GPS time and GNSS constants (GPS-ICD values named apart from WGS-84's), RINEX 2/3
observation and navigation reading and RINEX 3 writing, SP3 precise orbits, broadcast
ephemeris satellite position/velocity/clock (GPS, Galileo, BeiDou, GLONASS), pseudorange
and Doppler models with their corrections as CasADi functions, single-point positioning
(SPP) with RAIM/FDE, and a simulated constellation and measurement generator.
Uses the Earth model of `trackmodel.earth`.

The public names, importable from the package itself::

    from gnss_obs import read_rinex_obs, read_rinex_nav, solve_spp

==========================  =======================================================
topic                       names (owning module)
==========================  =======================================================
files                       `read_rinex_obs`, `RinexObs` (``rinex_obs``);
                            `read_rinex_nav`, `RinexNav` (``rinex_nav``);
                            `read_sp3`, `Sp3` (``sp3``)
GPS time                    `WEEK_S` (``constants``); `GPS_EPOCH`,
                            `calendar_to_gps_time_s`, `gps_time_s_to_calendar`,
                            `week_sow_to_gps_time_s`, `gps_time_s_to_week_sow`,
                            `to_gps_time_s`, `from_gps_time_s`,
                            `datetime64_to_gps_time_s`, `gps_time_s_to_datetime64`,
                            `leap_seconds_at`, `utc_datetime64_to_gps_time_s`,
                            `gps_time_s_to_utc_iso` (``gpstime``)
errors                      `GnssError`, `GnssInputError` (``errors``)
positioning                 `solve_spp`, `SppConfig`, `SppResult` (``spp``)
measurement selection       `MeasurementConfig`, `IONOSPHERE_MODELS`, `SIGMA_MODELS`,
                            `URBAN_CODE_SIGMAS`, `select_measurements`,
                            `glonass_channels` (``measurements``);
                            `known_position_residuals` (``residuals``)
epochs and models           `EpochData`, `PreparedEpoch`, `split_epochs`,
                            `prepare_epoch` (``epoch``); `transmit_states_batch`
                            (``transmission``);
                            `build_measurement_model` (``observables``);
                            `reissue_ephemerides` (``ephemeris_reissue``)
differential, smoothing,    `augment`, `Augmentation`, `DgpsConfig`, `base_corrections`,
precise orbits              `apply_corrections`, `base_position_e`, `augment_files`
                            (``dgps``);
                            `smooth_observations`, `SmoothingConfig`, `hatch_filter`
                            (``smoothing``); `PreciseOrbits` (``precise``)
receiver clock              `Oscillator`, `oscillator_from_name` (``oscillator``)
simulation                  `simulate_gnss`, `GnssSimConfig`, `default_nav_path`
                            (``simulate``); `GnssSimulation` (``sim_result``);
                            `Outage`, `SatelliteFault` (``sim_events``);
                            `write_simulation` (``sim_files``)
position fixes              `read_fixes`, `detect_fix_format` (``fixes.read``);
                            `FixLog`, `FIX_COLUMNS`, `FIX_QUALITIES` (``fixes.table``);
                            `FixSigmas`, `DEFAULT_FIX_SIGMAS` (``fixes.quality``);
                            `write_fixes_csv`, `write_fixes_nmea` (``fixes.writers``)
==========================  =======================================================

The names are imported on first use (PEP 562), so ``import gnss_obs`` stays cheap: it
imports neither CasADi nor SciPy nor pandas.
"""
from __future__ import annotations

import importlib

#: Public name -> the module that owns it.
_EXPORTS = {
    "read_rinex_obs": "rinex_obs", "RinexObs": "rinex_obs",
    "read_rinex_nav": "rinex_nav", "RinexNav": "rinex_nav",
    "read_sp3": "sp3", "Sp3": "sp3",
    "WEEK_S": "constants",
    "GPS_EPOCH": "gpstime", "calendar_to_gps_time_s": "gpstime",
    "gps_time_s_to_calendar": "gpstime", "week_sow_to_gps_time_s": "gpstime",
    "gps_time_s_to_week_sow": "gpstime", "to_gps_time_s": "gpstime",
    "from_gps_time_s": "gpstime", "datetime64_to_gps_time_s": "gpstime",
    "gps_time_s_to_datetime64": "gpstime", "leap_seconds_at": "gpstime",
    "utc_datetime64_to_gps_time_s": "gpstime", "gps_time_s_to_utc_iso": "gpstime",
    "GnssError": "errors", "GnssInputError": "errors",
    "solve_spp": "spp", "SppConfig": "spp", "SppResult": "spp",
    "MeasurementConfig": "measurements", "IONOSPHERE_MODELS": "measurements",
    "URBAN_CODE_SIGMAS": "measurements", "SIGMA_MODELS": "measurements",
    "select_measurements": "measurements", "glonass_channels": "measurements",
    "known_position_residuals": "residuals",
    "EpochData": "epoch", "PreparedEpoch": "epoch", "split_epochs": "epoch",
    "prepare_epoch": "epoch", "transmit_states_batch": "transmission",
    "build_measurement_model": "observables",
    "reissue_ephemerides": "ephemeris_reissue",
    "augment": "dgps", "augment_files": "dgps", "Augmentation": "dgps", "DgpsConfig": "dgps",
    "base_corrections": "dgps", "apply_corrections": "dgps", "base_position_e": "dgps",
    "smooth_observations": "smoothing", "SmoothingConfig": "smoothing",
    "hatch_filter": "smoothing", "PreciseOrbits": "precise",
    "Oscillator": "oscillator", "oscillator_from_name": "oscillator",
    "simulate_gnss": "simulate", "GnssSimConfig": "simulate",
    "default_nav_path": "simulate", "GnssSimulation": "sim_result",
    "Outage": "sim_events", "SatelliteFault": "sim_events",
    "write_simulation": "sim_files",
    "read_fixes": "fixes.read", "detect_fix_format": "fixes.read", "FixLog": "fixes.table",
    "FIX_COLUMNS": "fixes.table", "FIX_QUALITIES": "fixes.table",
    "FixSigmas": "fixes.quality", "DEFAULT_FIX_SIGMAS": "fixes.quality",
    "write_fixes_csv": "fixes.writers", "write_fixes_nmea": "fixes.writers",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'gnss_obs' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"gnss_obs.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
