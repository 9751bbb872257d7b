"""railnav SPP against gnss-lib-py's weighted least squares on the urban drive (data/gnss/README.md).

Data: the full urban drive, a folder given as ``--data DIR`` (rover, 2020-11-29 12:40-12:48
GPST, its post-processed reference trajectory and two SP3 files; provenance in
``data/gnss/README.md``). Every solution is scored by `railnav.evaluation.spp_accuracy` on
the same epochs (those where every method has a fix and the reference has a position):
horizontal RMS / 95 %, vertical RMS, and the Doppler speed error against central
differences of the reference.

Solutions:

* ``railnav G``   — `solve_spp`, GPS L1 C/A, defaults (Klobuchar, Saastamoinen/Niell,
  10° mask, elevation and C/N0 weights, Huber + RAIM/FDE), Doppler velocity;
* ``railnav GE``  — the same with Galileo E1;
* ``gnss-lib-py`` — gnss-lib-py 1.1.0 ``solve_wls`` on GPS L1 C/A, unweighted (its default)
  and with elevation weights sin²(el). Position only (it has no Doppler velocity solver).

Fairness, documented (gnss-lib-py is a benchmark-only dependency):

* its ``RinexObs`` reads the RINEX epochs as UTC although they are GPS time (data README):
  every epoch is 18 s (the leap seconds) late; we subtract 18 000 ms from ``gps_millis``;
* its ``RinexNav`` does not read the RINEX 3.04 ``GPSA``/``GPSB`` lines (empty
  ``iono_params``): we give it the header's Klobuchar coefficients as read by `gnss_obs`;
* its per-epoch ephemeris choice (``get_time_cropped_rinex``) takes the latest record
  *before* the epoch, which drops the satellites whose only valid record is issued later:
  we give it, per satellite, the record with the nearest toe (the choice `gnss_obs` makes);
* its satellite states (``find_sv_location``: transmission time from the range to a
  receiver position, its Earth-rotation correction inside ``solve_wls``), clocks
  (polynomial + relativistic - TGD), Klobuchar and troposphere models (``calculate_
  pseudorange_corr``) are used as they are; corrections are evaluated at the file's
  approximate position, then once more at its own first-pass solution of each epoch;
* satellites below 10° elevation are removed, as in railnav.

Writes ``benchmarks/results/spp_real.json``. Run: ``python benchmarks/bench_spp_real.py
--data DIR`` (about a minute: gnss-lib-py reads RINEX through georinex).
"""
from __future__ import annotations

import argparse
import json
import platform
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from gnss_obs.measurements import MeasurementConfig
from gnss_obs.orbit_validation import compare_with_precise, orbit_clock_statistics
from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.rinex_obs import read_rinex_obs
from gnss_obs.sp3 import read_sp3
from gnss_obs.spp import SppConfig, solve_spp
from railnav.evaluation.spp_accuracy import accuracy_summary, read_reference_trajectory, spp_errors
from trackmodel.earth import ecef_to_geodetic
from trackmodel.files import atomic_write_text

from _data_dir import add_data_argument, checked_data_dir  # beside this file

REPO = Path(__file__).resolve().parents[1]
#: Files of the urban drive this benchmark reads from ``--data DIR``.
DATA_FILES = ("rover_obs.rnx", "broadcast_nav.rnx", "reference_trajectory.csv",
              "COD21340.sp3", "igr21340.sp3")
RESULTS = Path(__file__).resolve().parent / "results" / "spp_real.json"
LEAP_SECONDS_MS = 18_000.0  # GPST - UTC on 2020-11-29 (nav header LEAP SECONDS)
ELEVATION_MASK_DEG = 10.0
MS = 1e3


def run_railnav(obs, nav, systems: str) -> tuple[pd.DataFrame, float]:
    """railnav SPP with its defaults on `systems`; the spp.csv frame and the run time (s)."""
    t0 = time.perf_counter()
    result = solve_spp(obs, nav, SppConfig(measurement=MeasurementConfig(systems=systems)))
    return result.to_frame(), time.perf_counter() - t0


def _nearest_records(glp_nav, sv_ids: np.ndarray, gps_millis: float):
    toe_ms = (glp_nav["gps_week"] * 604_800.0 + glp_nav["t_oe"]) * MS
    idx = []
    for sv in np.atleast_1d(sv_ids):
        cand = np.flatnonzero(glp_nav["sv_id"] == sv)
        idx.append(cand[np.argmin(np.abs(toe_ms[cand] - gps_millis))])
    return glp_nav.copy(cols=idx)


def _glp_epochs(glp, gps, glp_nav, iono_params, rx_by_epoch):
    """gnss-lib-py measurements with its satellite states and corrections at given rx."""
    from gnss_lib_py.utils.gnss_models import calculate_pseudorange_corr
    from gnss_lib_py.utils.sv_models import find_sv_location

    frames = []
    for k, (ms, _, frame) in enumerate(glp.loop_time(gps, "gps_millis")):
        rx = rx_by_epoch(k, ms)
        eph = _nearest_records(glp_nav, frame["sv_id"], ms)
        sv, _, _ = find_sv_location(ms, rx, eph)
        state = glp.NavData()
        for row, value in zip(("x_rx_m", "y_rx_m", "z_rx_m", "vx_rx_mps", "vy_rx_mps",
                               "vz_rx_mps", "b_rx_m", "b_dot_rx_mps"), (*rx, 0, 0, 0, 0, 0)):
            state[row] = np.array([value], dtype=float)
        tropo, iono = calculate_pseudorange_corr(ms, state=state, ephem=eph, sv_posvel=sv,
                                                 iono_params=iono_params)
        f = frame.copy()
        for row in ("x_sv_m", "y_sv_m", "z_sv_m", "b_sv_m"):
            f[row] = sv[row]
        f["corr_pr_m"] = f["raw_pr_m"] + sv["b_sv_m"] - tropo - iono
        sat = np.vstack([sv["x_sv_m"], sv["y_sv_m"], sv["z_sv_m"]])
        el_deg = glp.ecef_to_el_az(np.reshape(rx, (3, 1)), sat)[0]
        f["el_deg"] = el_deg
        f["weights"] = np.sin(np.deg2rad(el_deg)) ** 2
        frames.append(f.where("el_deg", ELEVATION_MASK_DEG, "geq"))
    return glp.concat(*frames)


def run_gnss_lib_py(obs_path: Path, nav_path: Path, approx_e: np.ndarray, iono_alpha_beta
                    ) -> tuple[dict[str, pd.DataFrame], float]:
    """gnss-lib-py WLS on GPS L1 C/A (module docstring); frames per weighting, run time."""
    import gnss_lib_py as glp

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        obs = glp.RinexObs(str(obs_path))
        gps = obs.where("gnss_id", "gps").where("observation_code", "1C")
        gps["gps_millis"] = gps["gps_millis"] - LEAP_SECONDS_MS
        svs = [f"G{int(s):02d}" for s in np.unique(gps["sv_id"])]
        glp_nav = glp.RinexNav(str(nav_path), satellites=svs)
        iono = {"gps": np.asarray(iono_alpha_beta, dtype=float)}
        first = _glp_epochs(glp, gps, glp_nav, iono, lambda k, ms: approx_e)
        out = {}
        for name, weight in (("unweighted", None), ("elevation-weighted", "weights")):
            pass1 = glp.solve_wls(first, weight_type=weight)
            rx = np.vstack([pass1["x_rx_wls_m"], pass1["y_rx_wls_m"], pass1["z_rx_wls_m"]]).T
            rx = np.where(np.isfinite(rx), rx, approx_e)
            second = _glp_epochs(glp, gps, glp_nav, iono, lambda k, ms: rx[k])
            state = glp.solve_wls(second, weight_type=weight)
            out[name] = _glp_frame(state)
    return out, time.perf_counter() - t0


def _glp_frame(state) -> pd.DataFrame:
    r_e = np.vstack([state["x_rx_wls_m"], state["y_rx_wls_m"], state["z_rx_wls_m"]]).T
    lat, lon, h = ecef_to_geodetic(r_e)
    return pd.DataFrame({"gps_time_s": np.asarray(state["gps_millis"]) / MS,
                         "lat_deg": np.rad2deg(lat), "lon_deg": np.rad2deg(lon), "h_m": h})


def _scores(solutions: dict[str, pd.DataFrame], reference: pd.DataFrame) -> dict:
    errors = {k: spp_errors(v, reference) for k, v in solutions.items()}
    common = None
    for e in errors.values():
        t = set(np.round(e.loc[np.isfinite(e["horizontal_m"]), "gps_time_s"], 3))
        common = t if common is None else common & t
    out = {}
    for name, e in errors.items():
        same = e[np.isin(np.round(e["gps_time_s"], 3), sorted(common))]
        out[name] = accuracy_summary(same).__dict__
    return out


def orbit_figures(data: Path, nav) -> dict:
    """Broadcast vs CODE final and IGS rapid, per system (gnss_obs.orbit_validation)."""
    out = {}
    for name in ("COD21340.sp3", "igr21340.sp3"):
        sp3 = read_sp3(data / name)
        stats = orbit_clock_statistics(compare_with_precise(nav.records, sp3.table))
        out[name] = {s: {k: float(v) for k, v in row.items()} for s, row in stats.iterrows()}
    return out


def drive_inputs(description: str, data_files: tuple[str, ...], results: Path, argv=None):
    """The command line of a benchmark on the whole drive (``--data DIR``, ``--out``,
    ``--skip-gnss-lib-py``) parsed, and the drive read: ``(args, obs_path, nav_path, obs,
    nav, reference)``. A folder without `data_files` is the parser's one-line error."""
    parser = argparse.ArgumentParser(description=description)
    add_data_argument(parser, data_files)
    parser.add_argument("--out", type=Path, default=results)
    parser.add_argument("--skip-gnss-lib-py", action="store_true")
    args = parser.parse_args(argv)
    checked_data_dir(parser, args.data, data_files)
    obs_path, nav_path = args.data / "rover_obs.rnx", args.data / "broadcast_nav.rnx"
    obs, nav = read_rinex_obs(obs_path), read_rinex_nav(nav_path)
    reference = read_reference_trajectory(args.data / "reference_trajectory.csv")
    return args, obs_path, nav_path, obs, nav, reference


def main(argv=None) -> dict:
    args, obs_path, nav_path, obs, nav, reference = drive_inputs(
        __doc__.splitlines()[0], DATA_FILES, RESULTS, argv)
    solutions, seconds = {}, {}
    for systems in ("G", "GE"):
        solutions[f"railnav {systems}"], seconds[f"railnav {systems}"] = run_railnav(
            obs, nav, systems)
    if not args.skip_gnss_lib_py:
        glp_frames, seconds["gnss-lib-py (both weightings)"] = run_gnss_lib_py(
            obs_path, nav_path, obs.header.approx_position_e,
            [nav.header.iono_gps_alpha, nav.header.iono_gps_beta])
        solutions.update({f"gnss-lib-py G {k}": v for k, v in glp_frames.items()})
    report = {"data": args.data.resolve().name, "epochs": int(obs.table["gps_time_s"].nunique()),
              "accuracy_same_epochs": _scores(solutions, reference),
              "accuracy_all_epochs": {k: accuracy_summary(spp_errors(v, reference)).__dict__
                                      for k, v in solutions.items()},
              "seconds": seconds, "orbits": orbit_figures(args.data, nav),
              "python": platform.python_version(), "machine": platform.machine()}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out, json.dumps(report, indent=2) + "\n")
    for name, acc in report["accuracy_same_epochs"].items():
        print(f"{name:32s} n={acc['n_epochs']:3d}  H RMS {acc['horizontal_rms_m']:.2f} m  "
              f"H95 {acc['horizontal_95_m']:.2f} m  V RMS {acc['vertical_rms_m']:.2f} m  "
              f"speed RMS {acc['speed_rms_mps']:.3f} m/s")
    return report


if __name__ == "__main__":
    main()
