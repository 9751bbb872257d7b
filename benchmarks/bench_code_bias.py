"""Calibration of the gnss-only filter's real-data error model on the shared urban drive:
the slow code error (`railnav.filters.code_bias`) and the velocity's angle to the track
(`railnav.filters.gnss_only_noise`), fitted on a calibration window and checked on the rest.

Data: the full urban drive, ``--data DIR`` (rover 2020-11-29 12:40-12:48 GPST, PPK
reference; provenance in ``data/gnss/README.md``). The pieces are `bench_real_pieces`'s
(each with its own track fitted from the reference). **Calibration**: leg 1 parts 1-3
(12:40:00 up to the end of part 3, the drive's first ~3 minutes); **held out**: leg 1 parts
4-6, leg 2 and leg 2 with the U-turn.

Per piece, on the filter's own rows (`railnav.filters.gnss_only.GnssOnlyFilter`, GPS L1, the
run's defaults) at the reference's ``s`` on the piece's track:

* the single-epoch along-track error ``e``: the epoch's pseudorange rows solved alone by
  weighted least squares for ``s`` and the clock, with their white σ, and its σ_1
  (`railnav.filters.code_bias.snapshot_variance_s`);
* ``RMS(e / σ_1)``, and the RMS of its centred `SLOW_WINDOW_S` mean (the slow part: what the
  model's k stands for; the rows' own variance stands for the rest);
* the correlation of ``e`` with the single-point fix's along-track error on the same
  epochs (``Σ ab / √(Σa² Σb²)``, not de-meaned: a common bias counts), the share of a
  start fix's error that the rows' slow error shares;
* the angle ψ between the reference velocity (central differences) and the track's tangent
  at speeds above `MIN_SPEED_MPS`, and the least-squares fit ``ψ² ≈ σ_0² + (κ d)²``
  (`railnav.NavigatorConfig.track_heading_sigma_rad`, ``track_heading_curvature_m``).

Also, on leg 1's track over the calibration window, the autocorrelation of ``e / σ_1`` at
`LAGS_S` (de-meaned, and raw: a bias counts), for τ_b.

Writes ``benchmarks/results/code_bias.json``. Run: ``python benchmarks/bench_code_bias.py
--data DIR`` (a minute).
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _data_dir import add_data_argument, checked_data_dir  # noqa: E402
from bench_real_pieces import CALIBRATION_PIECES, DATA_FILES, load_drive, pieces  # noqa: E402

from railnav.config import NavigatorConfig  # noqa: E402
from railnav.filters.code_bias import snapshot_variance_s  # noqa: E402
from railnav.filters.gnss_epochs import GnssEpochs  # noqa: E402
from railnav.filters.gnss_only import GnssOnlyFilter  # noqa: E402
from trackmodel.earth import C_n_e, geodetic_to_ecef  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "code_bias.json"
#: Window of the centred mean that is the slow part, s (beyond the fast part's ~20 s).
SLOW_WINDOW_S = 31
#: Lags of the autocorrelation, s.
LAGS_S = (1, 5, 10, 20, 40, 60, 90, 120)
#: Speeds below this have no heading, m/s.
MIN_SPEED_MPS = 2.0


def single_epoch_errors(piece: dict, obs, nav, reference: pd.DataFrame,
                        spp: pd.DataFrame, config: NavigatorConfig) -> pd.DataFrame:
    """``gps_time_s, e_m, sigma_1_m, spp_e_m`` of a piece (module docstring)."""
    track = piece["track"]
    times = reference["gps_time_s"].to_numpy()[piece["rows"]]
    t0 = float(times[0])
    gnss = GnssEpochs.from_files(obs, nav, config.measurement, start_gps_time_s=t0,
                                 end_s=float(times[-1]) - t0,
                                 elevation_mask_deg=config.elevation_mask_deg)
    filt = GnssOnlyFilter(track, config, gnss)
    layout = filt.layout
    i_s, i_c = layout.index("s"), layout.index("clock_bias")
    ref = reference.set_index(np.round(reference["gps_time_s"]))
    fixes = spp.set_index(np.round(spp["gps_time_s"]))
    rows = []
    for k in range(len(gnss)):
        gt = round(float(gnss.time_s[k]) + t0)
        if gt not in ref.index:
            continue
        r = ref.loc[gt]
        s_ref = float(track.project(np.radians([r["lat_deg"]]), np.radians([r["lon_deg"]])).s[0])
        x = np.zeros(layout.size)
        x[i_s] = s_ref
        pr = filt.rows.observations(k, x)[0]
        z_pred, H = pr.model.evaluate(x, pr.p)
        w = 1.0 / np.sqrt(pr.R)
        solution, *_ = np.linalg.lstsq(H[:, [i_s, i_c]] * w[:, None],
                                       (pr.z.ravel() - z_pred) * w, rcond=None)
        spp_e = np.nan
        if gt in fixes.index:
            f = fixes.loc[gt]
            spp_e = float(track.project(np.radians([f["lat_deg"]]),
                                        np.radians([f["lon_deg"]])).s[0]) - s_ref
        rows.append((gt, float(solution[0]),
                     np.sqrt(snapshot_variance_s(H, pr.R, i_s, (i_c,))), spp_e))
    return pd.DataFrame(rows, columns=["gps_time_s", "e_m", "sigma_1_m", "spp_e_m"])


def heading_mismatch(piece: dict, reference: pd.DataFrame) -> pd.DataFrame:
    """``psi_rad, kappa_1pm`` at the piece's reference epochs faster than `MIN_SPEED_MPS`."""
    track, ref = piece["track"], reference.iloc[piece["rows"]]
    lat, lon = np.radians(ref["lat_deg"].to_numpy()), np.radians(ref["lon_deg"].to_numpy())
    r_e = np.asarray(geodetic_to_ecef(lat, lon, ref["h_m"].to_numpy()))
    v_e = np.gradient(r_e, ref["gps_time_s"].to_numpy(), axis=0)
    v_n = np.einsum("kji,kj->ki", C_n_e(lat, lon), v_e)
    point = track.at(np.clip(track.project(lat, lon).s, 0.0, track.length_m))
    u = point.u_n
    psi = np.arctan2(v_n[:, 0] * u[:, 1] - v_n[:, 1] * u[:, 0],
                     v_n[:, 0] * u[:, 0] + v_n[:, 1] * u[:, 1])
    psi = np.where(np.abs(psi) > np.pi / 2, psi - np.sign(psi) * np.pi, psi)  # reversing
    fast = np.hypot(v_n[:, 0], v_n[:, 1]) > MIN_SPEED_MPS
    return pd.DataFrame({"psi_rad": psi[fast], "kappa_1pm": np.abs(point.curvature_1pm[fast])})


def summary(errors: list[pd.DataFrame], headings: list[pd.DataFrame]) -> dict:
    """The figures of one group of pieces (module docstring)."""
    z = np.concatenate([(e["e_m"] / e["sigma_1_m"]).to_numpy() for e in errors])
    slow = np.concatenate([
        (e["e_m"] / e["sigma_1_m"]).rolling(SLOW_WINDOW_S, center=True,
                                            min_periods=SLOW_WINDOW_S // 2).mean().to_numpy()
        for e in errors])
    both = pd.concat(errors).dropna()
    a, b = both["spp_e_m"].to_numpy(), both["e_m"].to_numpy()
    psi = pd.concat(headings)
    design = np.c_[np.ones(len(psi)), psi["kappa_1pm"] ** 2]
    (c0, c1), *_ = np.linalg.lstsq(design, psi["psi_rad"] ** 2, rcond=None)
    return {"epochs": int(z.size), "rms_e_over_sigma_1": float(np.sqrt(np.mean(z ** 2))),
            "rms_slow_over_sigma_1": float(np.sqrt(np.nanmean(slow ** 2))),
            "rms_e_m": float(np.sqrt(np.mean(np.concatenate([e["e_m"] for e in errors]) ** 2))),
            "correlation_spp_single_epoch": float(np.sum(a * b) / np.sqrt(np.sum(a * a)
                                                                          * np.sum(b * b))),
            "heading_epochs": int(len(psi)),
            "heading_sigma_0_rad": float(np.sqrt(max(c0, 0.0))),
            "heading_curvature_m": float(np.sqrt(max(c1, 0.0)))}


def autocorrelation(errors: pd.DataFrame) -> dict:
    """Autocorrelation of ``e / σ_1`` at `LAGS_S` on a continuous 1-s series (gaps NaN)."""
    z = pd.Series((errors["e_m"] / errors["sigma_1_m"]).to_numpy(),
                  index=errors["gps_time_s"].to_numpy())
    z = z.reindex(np.arange(z.index.min(), z.index.max() + 1)).to_numpy()
    mean, var = np.nanmean(z), np.nanvar(z)
    out = {}
    for lag in LAGS_S:
        a, b = z[:-lag], z[lag:]
        ok = np.isfinite(a) & np.isfinite(b)
        out[f"{lag} s"] = {
            "demeaned": float(np.mean((a[ok] - mean) * (b[ok] - mean)) / var),
            "raw": float(np.sum(a[ok] * b[ok]) / np.sqrt(np.sum(a[ok] ** 2) * np.sum(b[ok] ** 2)))}
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_data_argument(parser, DATA_FILES)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    data = checked_data_dir(parser, args.data, DATA_FILES)
    started = time.perf_counter()
    obs, nav, reference, spp = load_drive(data)
    config = NavigatorConfig(filter="gnss-only")
    groups: dict[str, tuple[list, list]] = {"calibration": ([], []), "held_out": ([], [])}
    per_piece, leg1 = {}, None
    for piece in pieces(reference):
        errors = single_epoch_errors(piece, obs, nav, reference, spp, config)
        if piece["name"] == "leg 1":
            leg1 = errors
            continue
        if piece["name"] == "leg 2":          # its epochs are in "leg 2 with the U-turn"
            continue
        heading = heading_mismatch(piece, reference)
        group = "calibration" if piece["name"] in CALIBRATION_PIECES else "held_out"
        groups[group][0].append(errors)
        groups[group][1].append(heading)
        per_piece[piece["name"]] = {"group": group, **summary([errors], [heading])}
    end_calibration = max(float(e["gps_time_s"].max()) for e in groups["calibration"][0])
    out = {"data": "gnss_urban_drive", "calibration_pieces": list(CALIBRATION_PIECES),
           "slow_window_s": SLOW_WINDOW_S,
           **{name: summary(*lists) for name, lists in groups.items()},
           "autocorrelation_calibration_leg_1": autocorrelation(
               leg1[leg1["gps_time_s"] <= end_calibration]),
           "pieces": per_piece,
           "seconds": time.perf_counter() - started, "machine": platform.platform()}
    for name in ("calibration", "held_out"):
        g = out[name]
        print(f"{name:12s} {g['epochs']} epochs: RMS e/σ_1 {g['rms_e_over_sigma_1']:.2f}, slow "
              f"{g['rms_slow_over_sigma_1']:.2f}; corr(SPP, single epoch) "
              f"{g['correlation_spp_single_epoch']:.2f}; heading σ_0 "
              f"{g['heading_sigma_0_rad']:.3f} rad, d {g['heading_curvature_m']:.2f} m")
    print("autocorrelation (calibration, leg 1's track): " + ", ".join(
        f"{k} {v['demeaned']:.2f}/{v['raw']:.2f}"
        for k, v in out["autocorrelation_calibration_leg_1"].items()))
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    print(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
