"""Does the single-point Doppler run slow? Doppler, the rover's own carrier phase, and the
PPK reference, second by second over the whole urban drive (issue 14).

Data: the full urban drive, ``--data DIR`` (rover 2020-11-29 12:40-12:48 GPST, 1 Hz,
Septentrio mosaic-X5; PPK reference; provenance in ``data/gnss/README.md``).

Three measures of the rover's motion, independent of one another:

* **Doppler**: ``-λ D`` per satellite (`gnss_obs.measurements`), and the single-point
  velocity from it (`gnss_obs.solve_spp`, GPS L1 as the filters' default, and GPS+Galileo);
* **carrier (TDCP)**: ``λ (L(t) - L(t-1))`` per satellite, and the displacement over
  ``[t-1, t]`` from GPS+Galileo L1C carrier phases, time-differenced: satellites at both
  transmission instants (`gnss_obs.epoch.prepare_epoch`, broadcast orbits and clocks),
  the line of sight from the GPS+Galileo single-point position at ``t-1`` (not the
  reference), unknowns ``Δr`` (3) and the clock step, from the largest consistent subset
  of satellites (`_carrier_phase.tdcp`). Its mean velocity over the second is the
  velocity at ``t - 0.5 s``; the mean of the seconds before and after ``t``, at ``t``
  (to jerk·Δt²/6);
* **reference**: the PPK positions' backward and central differences.

The questions of the brief (``bench_real_pieces.py``: "the Doppler speed ran 0.2-0.6 m/s
low for 10 s ... summed over 45966-45983, -2.1 m"): (a) a time-tag or averaging lag:
``Doppler(t) - rate(t - 0.5) = w (rate(t + 0.5) - rate(t - 0.5))``, the Doppler's instant
``t - τ``, ``τ = 0.5 - w`` (`doppler_instant`), per signal and along the track; (b) the
model's terms: the mean Doppler-minus-carrier per signal, the speed's mean, the σ model
(residuals less the epoch's median, over ``sigma_rr``), the error's whiteness, the
receiver clock; (c) the reference's lag and displacement against the carrier, per second,
over `WINDOWS`, and the odd one of the three where two agree within `VOTE_AGREE_MPS`.

Findings (``results/doppler_carrier.json``; 404 carrier seconds, median 9 satellites,
residual 7 mm RMS): the Doppler neither lags nor is mis-modelled; its errors are white,
0.18 m/s RMS in the GPS L1 speed, and the reference shares the "slow Doppler" stretch.

* (a) No lag. Per signal the Doppler is the carrier's range rate at ``t - τ`` with
  τ = +0.012 ... +0.045 s (GPS L1 +0.023 s; RMS against the carrier's central rate
  0.12 m/s, against the rate over the second before 0.20 m/s). Along the track, the
  single-point speed's τ is -0.032 s (GPS L1) and -0.015 s (GPS+Galileo), 277 seconds.
* (b) No model error. Doppler minus carrier per signal: |mean| ≤ 0.007 m/s for all seven
  signals of three systems (a wrong wavelength or sign is a fraction of ~1 km/s). The
  σ model fits: normalized residuals RMS 1.01 (GPS L1), 0.90 (Galileo E1), 2.2 % / 1.2 %
  beyond 3. The speed against the carrier: mean -0.016 m/s, RMS 0.18 (GPS L1), -0.002 and
  0.12 (GPS+Galileo); autocorrelation at 1-5 s within ±0.13 (white: 17 s of it integrate
  to ±0.7 m at 1σ). The receiver clock's step per second: 0.13 m/s RMS (max 0.8, mean
  +0.003 over 8 minutes): white-like, mean-reverting, not the filters' ``tcxo`` random
  walk (0.19 m/s per √s); the filters with the preset's q_b ×8, or q_d ×4 or ×16: the
  U-turn piece's figures move by ≤ 0.01 m, other pieces' both ways (q_d ×4: leg 1 part
  4's maximum 5.49 → 3.71 m, part 2's 3.74 → 4.14 m): not the cause, left as it is.
* (c) The reference does not lag (-0.005 s), but its displacement leaves the carrier's
  on 2.9 % of seconds by more than 0.3 m/s (RMS 0.11, median 0.02 m/s). Where the three
  disagree, the reference is the odd one out on 20 seconds, the Doppler on 7, the
  carrier on 2 (of 400). Over 45966-45983 (the U-turn piece's "Doppler -2.1 m"), on the
  14 seconds with all three: Doppler minus reference -1.20 m = Doppler minus carrier
  -0.77 m (GPS L1; GPS+Galileo -0.65 m) + carrier minus reference -0.42 m.

The carrier solution matters: removing the largest residual one at a time (instead of
`_carrier_phase`'s subsets) kept wrong satellites on a few seconds with 5-6 left and put
0.97-1.42 m of that window on the reference.

The filters against the same carrier: ``bench_doppler_filters.py``.

Writes ``benchmarks/results/doppler_carrier.json``. Run: ``python
benchmarks/bench_doppler_carrier.py --data DIR`` (about a minute).
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
from _carrier_phase import carrier_rates, tdcp  # noqa: E402
from _data_dir import add_data_argument, checked_data_dir, read_drive  # noqa: E402

from gnss_obs.measurements import MeasurementConfig  # noqa: E402
from gnss_obs.spp import SppConfig, solve_spp  # noqa: E402
from trackmodel.earth import C_n_e, geodetic_to_ecef  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "doppler_carrier.json"
DATA_FILES = ("rover_obs.rnx", "broadcast_nav.rnx", "reference_trajectory.csv")
GPS_WEEK_S = 2134 * 604_800
#: Along-track statistics use the seconds faster than this, m/s.
MIN_SPEED_MPS = 1.0
VOTE_AGREE_MPS = 0.3
#: Windows of the brief (seconds of week): the U-turn piece's slow Doppler, leg 1's
#: reference step and acceleration.
WINDOWS = {"uturn_45966_45983": (45966, 45983), "leg1_45740_45780": (45740, 45780),
           "leg1_45769_45777": (45769, 45777), "drive": (45600, 46080)}


def doppler_instant(y: np.ndarray, back: np.ndarray, fwd: np.ndarray) -> dict:
    """Least-squares ``y - back = w (fwd - back) + c``: the Doppler's instant ``t - τ``,
    ``τ = 0.5 - w`` (s), and the misfit (m/s), `y` the Doppler rate or speed."""
    A = np.c_[fwd - back, np.ones(y.size)]
    (w, c), *_ = np.linalg.lstsq(A, y - back, rcond=None)
    mid = y - 0.5 * (back + fwd)
    return {"n": int(y.size), "tau_s": float(0.5 - w), "offset_mps": float(c),
            "mean_minus_mid_mps": float(mid.mean()),
            "rms_minus_mid_mps": float(np.sqrt(np.mean(mid ** 2))),
            "median_abs_minus_mid_mps": float(np.median(np.abs(mid))),
            "rms_minus_back_mps": float(np.sqrt(np.mean((y - back) ** 2))),
            "rms_after_fit_mps": float(np.sqrt(np.mean((y - back - A @ [w, c]) ** 2)))}


def observation_level(rates: pd.DataFrame, sigma: pd.DataFrame) -> dict:
    """Per signal `doppler_instant`; for GPS and Galileo L1 the range-rate σ model's
    normalized residuals (epoch's median removed: the clock drift's share)."""
    out = {f"{s} {c}": doppler_instant(g["doppler"].to_numpy(), g["back"].to_numpy(),
                                       g["fwd"].to_numpy())
           for (s, c), g in rates.groupby(["system", "signal"])}
    l1 = rates[rates["signal"] == "1C"].merge(sigma, on=["t", "sv"])
    r = l1["doppler"] - 0.5 * (l1["back"] + l1["fwd"])
    l1 = l1.assign(r=r - r.groupby(l1["t"]).transform("median"))
    for system, g in l1.groupby("system"):
        z = g["r"] / g["sigma_rr_mps"]
        out[f"{system} 1C"]["sigma_model"] = {
            "rms_z": float(np.sqrt(np.mean(z ** 2))),
            "robust_sigma_z": float(1.4826 * np.median(np.abs(z))),
            "share_beyond_3": float(np.mean(np.abs(z) > 3.0))}
    return out


def _enu(frame: pd.DataFrame, prefix: str) -> pd.DataFrame:
    return frame[["v_east_mps", "v_north_mps", "v_up_mps"]].set_axis(
        [f"{prefix}e", f"{prefix}n", f"{prefix}u"], axis=1)


def _ecef(frame: pd.DataFrame) -> np.ndarray:
    """ECEF positions (m), shape (N, 3), of a frame's ``lat_deg, lon_deg, h_m``."""
    return np.asarray(geodetic_to_ecef(np.radians(frame["lat_deg"].to_numpy()),
                                       np.radians(frame["lon_deg"].to_numpy()),
                                       frame["h_m"].to_numpy()))


def _by_second(frame: pd.DataFrame) -> pd.DataFrame:
    return frame.set_index(np.round(frame["gps_time_s"]).astype(np.int64) - GPS_WEEK_S)


def velocities(spp_g: pd.DataFrame, spp_ge: pd.DataFrame, carrier: pd.DataFrame,
               reference: pd.DataFrame, C_e_enu: np.ndarray) -> pd.DataFrame:
    """Per second of week: ENU velocities (m/s) ``D`` (Doppler, GPS), ``G`` (Doppler,
    GPS+Galileo), ``Tb``/``Tf`` (carrier over the second before/after), ``Rb``/``Rf``
    (reference), the single-point clock drift (m/s) and the carrier's clock step (m)."""
    g, ge, ref = _by_second(spp_g), _by_second(spp_ge), _by_second(reference)
    full = np.arange(min(g.index.min(), ref.index.min()), max(g.index.max(),
                                                               ref.index.max()) + 1)
    r_e = pd.DataFrame(_ecef(ref), index=ref.index).reindex(full)
    rb = pd.DataFrame((r_e - r_e.shift(1)).to_numpy() @ C_e_enu.T, index=full,
                      columns=["Rbe", "Rbn", "Rbu"])
    carrier = carrier.set_axis(carrier.index - GPS_WEEK_S).reindex(full)
    tb = carrier[["e", "n", "u"]].add_prefix("Tb")
    out = pd.concat([_enu(g, "D").reindex(full), _enu(ge, "G").reindex(full), tb,
                     tb.shift(-1).set_axis(["Tfe", "Tfn", "Tfu"], axis=1), rb,
                     rb.shift(-1).set_axis(["Rfe", "Rfn", "Rfu"], axis=1),
                     g["clock_drift_mps"].reindex(full).rename("drift"),
                     carrier[["clock_step_m", "sats", "rms_m"]]], axis=1)
    return out


def _h(v: pd.DataFrame, p: str) -> np.ndarray:
    return v[[f"{p}e", f"{p}n"]].to_numpy()


def along_track(v: pd.DataFrame) -> pd.DataFrame:
    """Horizontal speeds (m/s) of each velocity, on the seconds where the carrier's speed
    at ``t`` (the mean of ``Tb`` and ``Tf``) exceeds `MIN_SPEED_MPS`; the carrier's
    acceleration ``|Tf| - |Tb|`` (m/s²), and the Doppler speeds' mean over ``t-1, t``
    (``Db``, ``Gb``: the speed at ``t - 0.5``, as the carrier's and reference's ``b``).
    Speeds, not projections on one direction: the chord of a second on a 10°/s turn is
    0.1 % shorter than the arc, a projection of ``t-1``'s velocity on ``t``'s direction 1.5 %."""
    moving = np.linalg.norm(0.5 * (_h(v, "Tb") + _h(v, "Tf")), axis=1) > MIN_SPEED_MPS
    out = pd.DataFrame({p: np.linalg.norm(_h(v, p), axis=1)
                        for p in ("D", "G", "Tb", "Tf", "Rb", "Rf")}, index=v.index)
    for p in ("D", "G"):
        out[f"{p}b"] = 0.5 * (out[p] + out[p].shift(1))
    out["acc"] = out["Tf"] - out["Tb"]
    return out[moving]


def velocity_level(al: pd.DataFrame) -> dict:
    """(a) and (c) along the track: `doppler_instant` of the single-point Doppler speeds
    and of the reference's mean speed over ``[t-1, t]`` (its instant ``t - 0.5 - lag``)
    against the carrier, on the seconds where all are known."""
    ok = al[["D", "G", "Tb", "Tf", "Rb"]].notna().all(axis=1)
    a = al[ok]
    out = {name: doppler_instant(a[col].to_numpy(), a["Tb"].to_numpy(), a["Tf"].to_numpy())
           for name, col in (("doppler_gps", "D"), ("doppler_gps_galileo", "G"),
                             ("reference_over_second", "Rb"))}
    out["reference_over_second"]["reference_lag_s"] = \
        out["reference_over_second"]["tau_s"] - 0.5
    d = a["Rb"] - a["Tb"]
    out["reference_minus_carrier_same_second"] = {
        "rms_mps": float(np.sqrt(np.mean(d ** 2))), "median_abs_mps": float(d.abs().median()),
        "share_beyond_0p3": float(np.mean(d.abs() > VOTE_AGREE_MPS))}
    return out


def whiteness(al: pd.DataFrame, lags: int = 5) -> dict:
    """Autocorrelation at lags 1..`lags` s of the Doppler speeds' error against the carrier's
    central speed: white errors integrate as ``σ √T``, correlated ones faster."""
    full = al.reindex(np.arange(al.index.min(), al.index.max() + 1))
    out = {}
    for name, col in (("doppler_gps", "D"), ("doppler_gps_galileo", "G")):
        r = full[col] - 0.5 * (full["Tb"] + full["Tf"])
        r = r - r.mean()
        out[name] = [float((r * r.shift(k)).mean() / (r * r).mean())
                     for k in range(1, lags + 1)]
    return out


def windows(al: pd.DataFrame) -> dict:
    """Per `WINDOWS` entry: the along-track displacement differences (m) summed over the
    seconds where the Doppler means, the carrier and the reference are all known."""
    out = {}
    for name, (a, b) in WINDOWS.items():
        w = al.loc[a:b]
        w = w[w[["Db", "Gb", "Tb", "Rb"]].notna().all(axis=1)]
        out[name] = {"seconds": [a, b], "seconds_used": int(len(w)),
                     "doppler_gps_minus_carrier_m": float((w["Db"] - w["Tb"]).sum()),
                     "doppler_gps_galileo_minus_carrier_m": float((w["Gb"] - w["Tb"]).sum()),
                     "reference_minus_carrier_m": float((w["Rb"] - w["Tb"]).sum()),
                     "doppler_gps_minus_reference_m": float((w["Db"] - w["Rb"]).sum())}
    return out


def vote(v: pd.DataFrame) -> dict:
    """Per second, horizontal velocity over ``[t-1, t]`` from the GPS+Galileo Doppler (mean
    of ``t-1`` and ``t``), the carrier and the reference: where two agree within
    `VOTE_AGREE_MPS` and the third is further from both, that one is counted."""
    g = 0.5 * (_h(v, "G") + _h(v.shift(1), "G"))
    three = {"doppler": g, "carrier": _h(v, "Tb"), "reference": _h(v, "Rb")}
    ok = np.all([np.isfinite(x).all(axis=1) for x in three.values()], axis=0)
    names = list(three)
    counts = {n: 0 for n in names}
    for k in np.flatnonzero(ok):
        for i, odd in enumerate(names):
            a, b = (three[n][k] for j, n in enumerate(names) if j != i)
            far = min(np.linalg.norm(three[odd][k] - a), np.linalg.norm(three[odd][k] - b))
            if np.linalg.norm(a - b) <= VOTE_AGREE_MPS < far:
                counts[odd] += 1
    return {"seconds": int(ok.sum()), "odd_one_out": counts}


def clock(v: pd.DataFrame) -> dict:
    """The receiver clock: the carrier's clock step per second (m, the mean drift over the
    second) and the single-point drift (m/s) against the mean of the steps around ``t``."""
    step = v["clock_step_m"]
    around = 0.5 * (step + step.shift(-1))
    d = (v["drift"] - around).dropna()
    return {"carrier_clock_step_mean_m": float(step.mean()),
            "carrier_clock_step_std_m": float(step.std()),
            "carrier_clock_step_diff_std_m": float(step.diff().std()),
            "carrier_clock_step_max_abs_m": float(step.abs().max()),
            "spp_drift_std_mps": float(v["drift"].std()),
            "spp_drift_minus_carrier_rms_mps": float(np.sqrt(np.mean(d ** 2)))}


def drive_velocities(obs, nav, reference: pd.DataFrame):
    """`tdcp` (from the GPS+Galileo single-point positions) and `velocities` of the drive,
    ENU at the reference's first point: ``(carrier, sigma, v)``."""
    spp_g, spp_ge = (solve_spp(obs, nav, SppConfig(measurement=MeasurementConfig(
        systems=s))).to_frame() for s in ("G", "GE"))
    ok = np.isfinite(spp_ge["lat_deg"].to_numpy())
    positions = dict(zip(np.round(spp_ge["gps_time_s"][ok]).astype(int), _ecef(spp_ge[ok])))
    lat0, lon0 = np.radians(reference[["lat_deg", "lon_deg"]].to_numpy()[0])
    C_e_enu = C_n_e(lat0, lon0).T
    carrier, sigma = tdcp(obs, nav, positions, C_e_enu)
    return carrier, sigma, velocities(spp_g, spp_ge, carrier, reference, C_e_enu)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_data_argument(parser, DATA_FILES)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    data = checked_data_dir(parser, args.data, DATA_FILES)
    started = time.perf_counter()
    obs, nav, reference = read_drive(data)
    carrier, sigma, v = drive_velocities(obs, nav, reference)
    al = along_track(v)
    out = {"data": "gnss_urban_drive", "tdcp_seconds": int(len(carrier)),
           "tdcp_median_sats": float(carrier["sats"].median()),
           "tdcp_median_residual_rms_m": float(carrier["rms_m"].median()),
           "observation_level": observation_level(carrier_rates(obs.table), sigma),
           "velocity_level": velocity_level(al), "autocorrelation": whiteness(al),
           "windows": windows(al), "vote": vote(v),
           "clock": clock(v)}
    out.update(seconds=time.perf_counter() - started, machine=platform.platform())
    print(json.dumps({k: out[k] for k in ("velocity_level", "windows", "vote", "clock")},
                     indent=1))
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    print(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
