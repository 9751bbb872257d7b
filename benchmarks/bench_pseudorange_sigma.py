"""How large the pseudorange and Doppler errors of the urban drive really are, by C/N0 and
elevation, and the σ model calibrated on them (`gnss_obs.measurements.URBAN_CODE_SIGMAS`).

Data: the full urban drive, ``--data DIR`` (rover 2020-11-29 12:40-12:48 GPST with its PPK
reference trajectory, and the static base station MARE 15 km away; provenance in
``data/gnss/README.md``). GPS L1 C/A and Galileo E1, the project's corrections (Klobuchar,
troposphere, broadcast orbits), elevations ≥ 10°.

Residuals (`gnss_obs.residuals.known_position_residuals`): at the reference position of
each rover epoch (its velocity from central differences of the reference) and at the base's
known position (velocity zero), with a per-epoch clock (median) and per-file inter-system
bias removed.

Pieces: ``calibration`` 12:43:00 GPST to the U-turn (SoW 45966: `bench_real_pieces`'s
held-out start), where the ``additive`` model ``σ² = a² + b²/sin²el + c²·10^(max(45 -
C/N0, 0)/10)`` is fitted (non-negative least squares of the squared residuals); checked on
``excerpt`` (12:40:00-12:42:59, the shipped ``data/gnss/rover_obs_1240.rnx``),
``uturn`` (the U-turn and leg 2, SoW ≥ 45966) and ``base`` (open sky: not the same
conditions). Per piece and model: the RMS and the 1.4826·MAD of ``residual / σ`` overall
and per C/N0 class (< 35, 35-45, ≥ 45 dB-Hz), the share beyond 3. Also the binned spread
(RMS, 1.4826·MAD, count) of the residuals themselves, pseudorange and range rate, and how
long the pseudorange errors last (`autocorrelation`).

Writes ``benchmarks/results/pseudorange_sigma.json``. Run: ``python
benchmarks/bench_pseudorange_sigma.py --data DIR`` (about half a minute).
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import nnls

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _data_dir import add_data_argument, checked_data_dir, read_drive  # noqa: E402

from gnss_obs.dgps import base_position_e  # noqa: E402
from gnss_obs.measurements import URBAN_CODE_SIGMAS, MeasurementConfig  # noqa: E402
from gnss_obs.residuals import known_position_residuals  # noqa: E402
from gnss_obs.rinex_obs import read_rinex_obs  # noqa: E402
from railnav.evaluation.spp_accuracy import _reference_velocity  # noqa: E402
from trackmodel.earth import geodetic_to_ecef  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "pseudorange_sigma.json"
DATA_FILES = ("rover_obs.rnx", "base_obs.rnx", "broadcast_nav.rnx", "reference_trajectory.csv")
#: The base station's position (lat°, lon°, h m), the data README's.
BASE_LAT_LON_H = (41.528442315126028, 2.434318899878233, 86.764)
#: Piece bounds, GPS time s: 12:43:00 GPST (the shipped excerpt's end) and the U-turn.
EXCERPT_END_S = 1290688980.0
UTURN_START_S = 1290689166.0
CN0_CLASSES_DBHZ = ((0.0, 35.0), (35.0, 45.0), (45.0, 99.0))
CN0_BINS_DBHZ = [0, 30, 35, 40, 45, 50, 60]
ELEVATION_BINS_DEG = [10, 20, 30, 45, 60, 90]
SYSTEMS = "GE"
#: Lags of `autocorrelation`, s.
LAGS_S = (1.0, 5.0, 10.0, 20.0, 40.0, 60.0, 120.0)


def design(table: pd.DataFrame, cn0_ref_dbhz: float = 45.0) -> np.ndarray:
    """Columns of the ``additive`` variance model: 1, 1/sin²el, 10^(deficit/10)."""
    sin_el = np.sin(np.deg2rad(table["elevation_deg"].to_numpy()))
    deficit = np.maximum(cn0_ref_dbhz - table["cn0_dbhz"].to_numpy(), 0.0)
    return np.c_[np.ones(len(table)), 1.0 / sin_el ** 2, 10.0 ** (deficit / 10.0)]


def fit_additive(table: pd.DataFrame) -> dict:
    """``a, b, c`` (m) of the ``additive`` model by NNLS of the squared residuals."""
    coef, _ = nnls(design(table), table["pr_residual_m"].to_numpy() ** 2)
    a, b, c = np.sqrt(coef)
    return {"sigma_pr_m": float(a), "sigma_pr_elevation_m": float(b), "sigma_pr_cn0_m": float(c)}


def _spread(z: np.ndarray) -> dict:
    z = z[np.isfinite(z)]
    if not z.size:
        return {"n": 0}
    return {"n": int(z.size), "rms": float(np.sqrt(np.mean(z ** 2))),
            "mad_sigma": float(1.4826 * np.median(np.abs(z - np.median(z)))),
            "beyond_3": float(np.mean(np.abs(z) > 3.0))}


def normalized(table: pd.DataFrame, column: str, sigma: np.ndarray) -> dict:
    """Spread of ``column / sigma`` overall, per system and per C/N0 class."""
    z = table[column].to_numpy() / sigma
    cn0, system = table["cn0_dbhz"].to_numpy(), table["system"].to_numpy()
    out = {"all": _spread(z)}
    out.update({f"system {s}": _spread(z[system == s]) for s in SYSTEMS})
    out.update({f"cn0 {lo:g}-{hi:g}": _spread(z[(cn0 >= lo) & (cn0 < hi)])
                for lo, hi in CN0_CLASSES_DBHZ})
    return out


def binned(table: pd.DataFrame, column: str) -> dict:
    """RMS, 1.4826·MAD and count of ``column`` per C/N0 bin and per elevation bin."""
    out = {}
    for key, bins in (("cn0_dbhz", CN0_BINS_DBHZ), ("elevation_deg", ELEVATION_BINS_DEG)):
        cut = pd.cut(table[key], bins)
        rows = {}
        for interval, group in table.groupby(cut, observed=True):
            x = group[column].to_numpy()
            x = x[np.isfinite(x)]
            if x.size:
                rows[str(interval)] = {"n": int(x.size), "rms": float(np.sqrt(np.mean(x ** 2))),
                                       "mad_sigma": float(1.4826 * np.median(np.abs(x)))}
        out[key] = rows
    return out


def autocorrelation(table: pd.DataFrame, column: str) -> dict:
    """How long the errors last: ``Σ e(t) e(t+lag) / sqrt(Σ e(t)² Σ e(t+lag)²)`` over the
    pairs of one satellite's rows `lag` apart (not de-meaned: a bias counts), per lag in
    `LAGS_S`; and the share of the variance that is each satellite's mean over the piece."""
    out = {}
    keyed = table.set_index(["sv", "gps_time_s"])[column]
    for lag in LAGS_S:
        later = table.assign(gps_time_s=table["gps_time_s"] + lag).set_index(
            ["sv", "gps_time_s"])[column]
        pairs = pd.concat([keyed, later], axis=1, join="inner").dropna().to_numpy()
        if len(pairs):
            a, b = pairs[:, 0], pairs[:, 1]
            out[f"{lag:g} s"] = float(np.sum(a * b) / np.sqrt(np.sum(a * a) * np.sum(b * b)))
    values = table[column].to_numpy()
    means = table.groupby("sv")[column].transform("mean").to_numpy()
    ok = np.isfinite(values)
    out["share_of_variance_in_satellite_means"] = float(np.sum(means[ok] ** 2)
                                                        / np.sum(values[ok] ** 2))
    return out


def sigmas(table: pd.DataFrame, config: MeasurementConfig) -> tuple[np.ndarray, np.ndarray]:
    """The model's σ_pr, σ_rr of each row (`gnss_obs.epoch.measurement_sigmas`)."""
    from gnss_obs.epoch import measurement_sigmas
    n = len(table)
    return measurement_sigmas(np.deg2rad(table["elevation_deg"].to_numpy()),
                              table["cn0_dbhz"].to_numpy(), config,
                              frequency_hz=np.full(n, np.nan), frequency2_hz=np.full(n, np.nan))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_data_argument(parser, DATA_FILES)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    data = checked_data_dir(parser, args.data, DATA_FILES)
    started = time.perf_counter()
    rover_obs, nav, ref = read_drive(data)
    t = ref["gps_time_s"].to_numpy()
    r_e = np.asarray(geodetic_to_ecef(np.deg2rad(ref["lat_deg"].to_numpy()),
                                      np.deg2rad(ref["lon_deg"].to_numpy()), ref["h_m"].to_numpy()))
    old = MeasurementConfig(systems=SYSTEMS)
    rover = known_position_residuals(rover_obs, nav, old,
                                     times_s=t, r_e=r_e, v_e=_reference_velocity(t, r_e))
    base_obs = read_rinex_obs(data / "base_obs.rnx")
    base = known_position_residuals(base_obs, nav, old,
                                    times_s=np.unique(base_obs.table["gps_time_s"]),
                                    r_e=base_position_e(None, BASE_LAT_LON_H), v_e=np.zeros(3))
    tr = rover["gps_time_s"].to_numpy()
    pieces = {"calibration": rover[(tr >= EXCERPT_END_S) & (tr < UTURN_START_S)],
              "excerpt": rover[tr < EXCERPT_END_S], "uturn": rover[tr >= UTURN_START_S],
              "base": base}
    fitted = fit_additive(pieces["calibration"])
    new = replace(old, **URBAN_CODE_SIGMAS)
    models = {"product (old default)": old, "additive (URBAN_CODE_SIGMAS)": new}
    out = {"data": "gnss_urban_drive", "systems": SYSTEMS, "elevation_mask_deg": 10.0,
           "fitted_on_calibration": fitted, "urban_code_sigmas": URBAN_CODE_SIGMAS,
           "pieces_gps_time_s": {k: [float(v["gps_time_s"].min()), float(v["gps_time_s"].max())]
                                 for k, v in pieces.items()},
           "normalized_pseudorange": {}, "normalized_range_rate": {},
           "pseudorange_residual_m": {}, "range_rate_residual_mps": {}}
    for name, table in pieces.items():
        out["pseudorange_residual_m"][name] = binned(table, "pr_residual_m")
        out["range_rate_residual_mps"][name] = binned(table, "rr_residual_mps")
        out["normalized_pseudorange"][name] = {
            m: normalized(table, "pr_residual_m", sigmas(table, c)[0]) for m, c in models.items()}
        out.setdefault("pseudorange_autocorrelation", {})[name] = autocorrelation(
            table, "pr_residual_m")
        out["normalized_range_rate"][name] = normalized(table, "rr_residual_mps",
                                                        sigmas(table, old)[1])
        for m in models:
            s = out["normalized_pseudorange"][name][m]
            print(f"{name:12s} {m:30s} z RMS {s['all']['rms']:.2f} MAD {s['all']['mad_sigma']:.2f}"
                  " | C/N0 classes " + " ".join(
                      f"{s[k]['rms']:.2f}" if s[k]["n"] else "-" for k in s if k.startswith("cn0")))
    for name, ac in out["pseudorange_autocorrelation"].items():
        print(f"{name:12s} autocorrelation " + " ".join(f"{k} {v:.2f}" for k, v in ac.items()))
    print("fitted on calibration:", {k: round(v, 3) for k, v in fitted.items()})
    out["seconds"] = time.perf_counter() - started
    out["machine"] = platform.platform()
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    print(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
