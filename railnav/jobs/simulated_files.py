"""A simulated trip written as the files ``railnav simulate`` writes, which ``railnav run``
(`railnav.run_files`) reads back: `write_simulated_trip`.

Into the folder: ``truth.csv`` and ``imu.csv`` (17 significant digits: every float64
round-trips), the GNSS observations and the navigation file used (`gnss_obs.sim_files`),
``scenario.json`` (the scenario, the track's name, the seed, the GNSS systems, the sample
count and the end time, and an entry per file below: `railnav.simulation.trip`'s
``navigator_config_for_files`` and `railnav.jobs.scoring` read it), and, when asked, the
fixes of the truth (``fixes.csv`` or ``fixes.nmea``), ``odometer.csv``, ``balises.csv``,
``baro.csv``, ``imu.csv`` as a logger's jittered log with dropouts, and the route's line
``route_track.csv``.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

from trackmodel.files import atomic_write_csv, atomic_write_text

__all__ = ["write_simulated_trip", "FLOAT_FORMAT", "ROUTE_TRACK_FILE"]

#: CSV float format: 17 significant digits round-trip every float64 exactly.
FLOAT_FORMAT = "%.17g"
#: The route's line, a track file for ``railnav run`` (`write_simulated_trip`'s
#: ``route_track``).
ROUTE_TRACK_FILE = "route_track.csv"


def write_simulated_trip(trip, out_dir: str | os.PathLike, *, track_name: str = "",
                         fixes=None, fixes_format: str = "csv", odometer=None,
                         balises=None, baro=None, imu_log=None,
                         route_track: bool = False) -> tuple[list[Path], dict]:
    """Write `trip` into `out_dir` (module docstring); the paths written and the content of
    ``scenario.json``.

    Parameters
    ----------
    trip : railnav.simulation.trip.SimulatedTrip
        From `railnav.simulate_trip` (its seed and systems go into ``scenario.json``).
    out_dir : path
        An existing folder.
    track_name : str
        The track's name in ``scenario.json`` (``railnav simulate``: the file, or
        ``NETWORK:ROUTE``).
    fixes : railnav.simulation.fixes.FixSimConfig, optional
        Also the fixes of the truth (`railnav.trip_fixes`), in `fixes_format` (``"csv"``
        or ``"nmea"``; `railnav.simulation.fixes.FIX_FORMATS_WRITTEN`).
    odometer, balises, baro : OdometerSimConfig, BaliseSimConfig, BaroSimConfig, optional
        Also these sensors' files (`railnav.simulation.track_sensors`).
    imu_log : railnav.simulation.imu_logs.ImuLogSimConfig, optional
        ``imu.csv`` as a logger's: jittered sample instants, dropouts.
    route_track : bool
        Also the trip's track as ``route_track.csv`` (a route through a network).
    """
    from gnss_obs.sim_files import write_simulation
    out = Path(out_dir)
    result = trip.simulation
    written = list(write_simulation(out, trip.gnss, trip.nav)) if trip.gnss is not None else []
    if route_track:
        from trackmodel.io import write_track
        write_track(trip.track, out / ROUTE_TRACK_FILE, comments=[f"route {track_name}"])
        written.append(out / ROUTE_TRACK_FILE)
    atomic_write_csv(out / "truth.csv", result.truth.to_frame(), float_format=FLOAT_FORMAT)
    atomic_write_csv(out / "imu.csv", result.imu_measured.to_frame(), float_format=FLOAT_FORMAT)
    from railnav.simulation.scenarios import scenario_to_dict
    meta = {"scenario": scenario_to_dict(trip.scenario), "track": track_name,
            "seed": trip.seed, "gnss_written": trip.gnss is not None,
            "gnss_systems": trip.systems if trip.gnss is not None else None,
            "n_samples": int(len(result.truth.time_s)),
            "end_time_s": float(result.truth.time_s[-1])}
    if fixes is not None:
        meta["fixes"] = _write_fixes(out, trip, fixes, fixes_format)
        written.append(out / meta["fixes"]["file"])
    extra, entries = _write_sensors(out, trip, odometer=odometer, balises=balises, baro=baro,
                                    imu_log=imu_log)
    meta.update(entries)
    atomic_write_text(out / "scenario.json", json.dumps(meta, indent=2) + "\n")
    return [out / "truth.csv", out / "imu.csv", *written, *extra, out / "scenario.json"], meta


def _write_fixes(out: Path, trip, config, fmt: str) -> dict:
    """Write the fixes of the truth; their ``scenario.json`` entry."""
    from gnss_obs.fixes.writers import write_fixes_csv, write_fixes_nmea
    from railnav.simulation.fixes import trip_fixes
    fixes = trip_fixes(trip, config)
    name = f"fixes.{fmt}"
    (write_fixes_csv if fmt == "csv" else write_fixes_nmea)(out / name, fixes.table)
    return {"file": name, "format": fmt, "count": len(fixes), **config.to_dict()}


def _write_sensors(out: Path, trip, *, odometer, balises, baro, imu_log) -> tuple[list, dict]:
    """Write the asked sensors' files into `out`; their paths and ``scenario.json`` entries.

    ``imu.csv`` is rewritten as the jittered log when one is asked (after the uniform
    record: this writes the file last)."""
    from railnav.sensors.balises import write_balises_csv
    from railnav.sensors.odometer import write_odometer_csv
    from railnav.simulation.imu_logs import simulate_imu_log
    from railnav.simulation.track_sensors import (
        simulate_balises,
        simulate_baro_readings,
        simulate_odometer,
    )
    written, meta = [], {}
    if imu_log is not None:
        imu = simulate_imu_log(trip, imu_log)
        atomic_write_csv(out / "imu.csv", imu.to_frame(), float_format=FLOAT_FORMAT)
        meta["imu_log"] = {**imu_log.to_dict(), "samples": int(imu.time_s.size)}
    if odometer is not None:
        odo = simulate_odometer(trip, odometer)
        values = {k: odo[k] for k in ("speed_mps", "pulses") if k in odo}
        write_odometer_csv(out / "odometer.csv", odo["time_s"], **values)
        meta["odometer"] = {"file": "odometer.csv", **odometer.to_dict(odo["scale_error"])}
        written.append(out / "odometer.csv")
    if balises is not None:
        bal = simulate_balises(trip, balises)
        write_balises_csv(out / "balises.csv", bal["time_s"], bal["s_m"], sigma_m=bal["sigma_m"],
                          ids=bal["id"])
        meta["balises"] = {"file": "balises.csv", "passages": int(bal["time_s"].size),
                           **balises.to_dict()}
        written.append(out / "balises.csv")
    if baro is not None:
        import pandas as pd
        readings = simulate_baro_readings(trip, baro)
        atomic_write_csv(out / "baro.csv", pd.DataFrame(readings), float_format=FLOAT_FORMAT)
        meta["baro"] = {"file": "baro.csv", "readings": int(readings["time_s"].size),
                        **baro.to_dict()}
        written.append(out / "baro.csv")
    return written, meta
