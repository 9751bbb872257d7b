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
  reference), unknowns ``Δr`` (3) and the receiver clock step, residuals over
  `TDCP_MAX_RESIDUAL_M` removed one by one, at least `TDCP_MIN_SATS` satellites. Its mean
  velocity over the second is the velocity at ``t - 0.5 s``; the mean of the seconds before
  and after ``t`` is the velocity at ``t`` to ``jerk·Δt²/6``;
* **reference**: the PPK positions' backward and central differences.

The questions of the brief (benchmarks/bench_real_pieces.py's docstring: "the Doppler speed
ran 0.2-0.6 m/s low for 10 s ... summed over 45966-45983, -2.1 m"):

(a) a time-tag or averaging lag: Doppler(t) - carrier rate at ``t - 0.5`` fitted as
    ``w · (rate(t + 0.5) - rate(t - 0.5))``, the Doppler's instant is ``t - τ`` with
    ``τ = 0.5 - w``; per signal (observation level) and along the track (velocity level);
(b) the model's terms: the mean Doppler-minus-carrier per signal (a wrong wavelength or
    sign would show as a fraction of ~1 km/s of range rate), the mean velocity difference
    (satellite velocities, clock drifts), the range-rate σ model (residuals with the
    epoch's common part removed, over ``sigma_rr``), and the receiver clock (the carrier's
    clock step per second);
(c) the reference's own lag and its displacement against the carrier: per second, and
    summed over the windows of `WINDOWS`; per second, the odd one of the three measures
    where two agree within `VOTE_AGREE_MPS` and the third is off both by more.

Findings (``results/doppler_carrier.json``; 434 carrier seconds, median 9 satellites,
residual 8 mm RMS): the Doppler neither lags nor is mis-modelled; the reference is what
disagrees with the carrier where "the Doppler ran slow".

* (a) No lag. Per signal the Doppler is the carrier's range rate at ``t - τ`` with
  τ = +0.012 ... +0.045 s (GPS L1 +0.023 s; RMS against the carrier's central rate
  0.12 m/s, against the rate over the second before 0.20 m/s). Along the track, the
  single-point speed's τ is -0.024 s (GPS L1) and -0.018 s (GPS+Galileo), 324 seconds.
* (b) No model error. Doppler minus carrier per signal: |mean| ≤ 0.007 m/s for all seven
  signals of three systems (a wrong wavelength or sign is a fraction of ~1 km/s). The
  σ model fits: normalized residuals RMS 1.01 (GPS L1), 0.90 (Galileo E1), 2.2 % / 1.2 %
  beyond 3. The speed's mean against the carrier: -0.021 m/s (GPS L1, RMS 0.25; its
  standard error, 0.25/√324 = 0.014, with errors correlated over seconds) and +0.005 m/s
  (GPS+Galileo, RMS 0.13). The receiver clock steps by 0.18 m/s RMS second to second
  (first difference 0.17, max 1.9), mean -0.009 m/s over 8 minutes: white-like,
  mean-reverting frequency noise, not the filters' ``tcxo`` random walk (0.19 m/s per
  √s). The filters with the preset's q_b ×8, or q_d ×4 or ×16: the U-turn piece's
  figures move by ≤ 0.01 m; other pieces' both ways (q_d ×4: leg 1 part 4's maximum
  5.49 → 3.71 m, part 2's 3.74 → 4.14 m); not the cause, left as it is.
* (c) The reference does not lag (-0.027 s), but its displacement leaves the carrier's
  on 4.6 % of seconds by more than 0.3 m/s (RMS 0.13, median 0.02 m/s). Where the three
  disagree, the reference is the odd one out on 19 seconds, the carrier on 9, the Doppler
  on 7 (of 430). Over 45966-45983 (the U-turn piece's "Doppler -2.1 m"), summed on the
  18 seconds faster than 1 m/s: Doppler minus reference -1.71 m = Doppler minus carrier
  -0.74 m (GPS L1; -0.54 m GPS+Galileo) + carrier minus reference -0.97 m.

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
from _data_dir import add_data_argument, checked_data_dir  # noqa: E402

from gnss_obs.constants import SPEED_OF_LIGHT_MPS  # noqa: E402
from gnss_obs.epoch import prepare_epoch, split_epochs  # noqa: E402
from gnss_obs.measurements import MeasurementConfig, select_measurements  # noqa: E402
from gnss_obs.rinex_nav import read_rinex_nav  # noqa: E402
from gnss_obs.rinex_obs import read_rinex_obs  # noqa: E402
from gnss_obs.spp import SppConfig, solve_spp  # noqa: E402
from railnav.evaluation.spp_accuracy import read_reference_trajectory  # noqa: E402
from trackmodel.earth import C_n_e, geodetic_to_ecef  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "doppler_carrier.json"
DATA_FILES = ("rover_obs.rnx", "broadcast_nav.rnx", "reference_trajectory.csv")
GPS_WEEK_S = 2134 * 604_800
L1_HZ = 1575.42e6
#: Signals compared at the observation level: (system, RINEX code) -> carrier frequency, Hz.
SIGNALS = {("G", "1C"): L1_HZ, ("G", "2L"): 1227.60e6, ("G", "5Q"): 1176.45e6,
           ("E", "1C"): L1_HZ, ("E", "5Q"): 1176.45e6, ("E", "7Q"): 1207.14e6,
           ("C", "2I"): 1561.098e6}
#: A carrier step further than this from the Doppler is a cycle slip, m/s.
SLIP_MPS = 1.0
TDCP_MAX_RESIDUAL_M = 0.05
TDCP_MIN_SATS = 5
TDCP_MIN_ELEVATION_RAD = np.radians(10.0)
#: Along-track statistics use the seconds faster than this, m/s.
MIN_SPEED_MPS = 1.0
VOTE_AGREE_MPS = 0.3
#: Windows of the brief (seconds of week): the U-turn piece's slow Doppler, leg 1's
#: reference step and acceleration.
WINDOWS = {"uturn_45966_45983": (45966, 45983), "leg1_45740_45780": (45740, 45780),
           "leg1_45769_45777": (45769, 45777), "drive": (45600, 46080)}


def carrier_rates(table: pd.DataFrame) -> pd.DataFrame:
    """Per signal of `SIGNALS`, satellite and second ``t`` with the seconds around it: the
    Doppler rate ``-λ D(t)``, the carrier rates over ``[t-1, t]`` (``back``) and
    ``[t, t+1]`` (``fwd``), m/s; no loss of lock, no step `SLIP_MPS` from the Doppler."""
    out = []
    for (system, code), freq in SIGNALS.items():
        lam = SPEED_OF_LIGHT_MPS / freq
        sig = table[(table["system"] == system) & (table["signal"] == code)]
        for sv, g in sig.groupby("sv"):
            g = g.sort_values("gps_time_s")
            t = np.round(g["gps_time_s"].to_numpy()).astype(np.int64)
            phase = lam * g["carrier_cycles"].to_numpy()
            lost = (np.nan_to_num(g["lli"].to_numpy()).astype(int) & 1) == 1
            step = np.full(t.size, np.nan)
            step[1:] = np.where((np.diff(t) == 1) & ~lost[1:], np.diff(phase), np.nan)
            rate = -lam * g["doppler_hz"].to_numpy()
            step[np.abs(step - rate) > SLIP_MPS] = np.nan
            out.append(pd.DataFrame({"system": system, "signal": code, "sv": sv, "t": t,
                                     "doppler": rate, "back": step,
                                     "fwd": np.r_[step[1:], np.nan],
                                     "cn0_dbhz": g["cn0_dbhz"].to_numpy()}))
    rates = pd.concat(out, ignore_index=True).dropna(subset=["doppler", "back", "fwd"])
    rates = rates[np.abs(rates["doppler"] - rates["fwd"]) <= SLIP_MPS]
    return rates.reset_index(drop=True)


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


def _tdcp_rows(p0, p1, r0: np.ndarray, phase: dict, t: int):
    """Rows ``[-e, 1]`` and values of the carrier step of the satellites in both epochs."""
    first = {sv: k for k, sv in enumerate(p0.sv)}
    H, y = [], []
    for j, sv in enumerate(p1.sv):
        i = first.get(sv)
        step = phase.get((t, sv))
        if i is None or step is None or not p1.elevation[j] >= TDCP_MIN_ELEVATION_RAD:
            continue
        rho0 = np.linalg.norm(p0.sat_pos_e[i] - r0)
        rho1 = np.linalg.norm(p1.sat_pos_e[j] - r0)
        H.append(np.r_[-(p1.sat_pos_e[j] - r0) / rho1, 1.0])
        y.append(step - (rho1 - rho0) + (p1.sat_clock_m[j] - p0.sat_clock_m[i]))
    return np.array(H), np.array(y)


def _robust_solve(H: np.ndarray, y: np.ndarray):
    """Least squares, the worst residual over `TDCP_MAX_RESIDUAL_M` removed one at a time."""
    keep = np.ones(y.size, dtype=bool)
    while keep.sum() >= TDCP_MIN_SATS:
        x, *_ = np.linalg.lstsq(H[keep], y[keep], rcond=None)
        res = np.where(keep, np.abs(y - H @ x), -1.0)
        worst = int(np.argmax(res))
        if res[worst] <= TDCP_MAX_RESIDUAL_M:
            return x, float(np.sqrt(np.mean(res[keep] ** 2))), int(keep.sum())
        keep[worst] = False
    return None


def tdcp(obs, nav, positions: dict, C_e_enu: np.ndarray) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per second ``t``: the carrier displacement over ``[t-1, t]`` (ENU, m), the receiver
    clock step (m), satellites and residual RMS (m); `positions` ``{t: r_e}`` the line of
    sight's origin. Second frame: ``t, sv, sigma_rr_mps`` of the filters' σ model there."""
    mc = MeasurementConfig(systems="GE")
    epochs = {int(round(e.gps_time_s)): e
              for e in split_epochs(select_measurements(obs.table, mc), nav.records, mc)}
    l1 = carrier_rates(obs.table)
    l1 = l1[l1["signal"] == "1C"]
    phase = dict(zip(zip(l1["t"], l1["sv"]), l1["back"]))
    rows, sigmas = [], []
    for t in sorted(epochs):
        if t - 1 not in epochs or t - 1 not in positions:
            continue
        r0 = positions[t - 1]
        p0 = prepare_epoch(epochs[t - 1], mc, r_rx_e=r0)
        p1 = prepare_epoch(epochs[t], mc, r_rx_e=r0)
        sigmas.append(pd.DataFrame({"t": t, "sv": p1.sv, "sigma_rr_mps": p1.sigma_rr_mps}))
        H, y = _tdcp_rows(p0, p1, r0, phase, t)
        solved = _robust_solve(H, y) if y.size >= TDCP_MIN_SATS else None
        if solved is not None:
            x, rms, n = solved
            rows.append((t, *(C_e_enu @ x[:3]), x[3], n, rms))
    return (pd.DataFrame(rows, columns=["t", "e", "n", "u", "clock_step_m", "sats",
                                        "rms_m"]).set_index("t"),
            pd.concat(sigmas, ignore_index=True))


def _enu(frame: pd.DataFrame, prefix: str) -> pd.DataFrame:
    return frame[["v_east_mps", "v_north_mps", "v_up_mps"]].set_axis(
        [f"{prefix}e", f"{prefix}n", f"{prefix}u"], axis=1)


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
    r_e = pd.DataFrame(np.array([np.asarray(geodetic_to_ecef(
        np.radians(a), np.radians(b), h)).ravel() for a, b, h in zip(
        ref["lat_deg"], ref["lon_deg"], ref["h_m"])]), index=ref.index).reindex(full)
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
    positions = {int(round(t)): np.asarray(geodetic_to_ecef(
        np.radians(a), np.radians(b), h)).ravel() for t, a, b, h in zip(
        spp_ge["gps_time_s"][ok], spp_ge["lat_deg"][ok], spp_ge["lon_deg"][ok],
        spp_ge["h_m"][ok])}
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
    obs = read_rinex_obs(data / "rover_obs.rnx")
    nav = read_rinex_nav(data / "broadcast_nav.rnx")
    reference = read_reference_trajectory(data / "reference_trajectory.csv")
    carrier, sigma, v = drive_velocities(obs, nav, reference)
    al = along_track(v)
    out = {"data": "gnss_urban_drive", "tdcp_seconds": int(len(carrier)),
           "tdcp_median_sats": float(carrier["sats"].median()),
           "tdcp_median_residual_rms_m": float(carrier["rms_m"].median()),
           "observation_level": observation_level(carrier_rates(obs.table), sigma),
           "velocity_level": velocity_level(al), "windows": windows(al), "vote": vote(v),
           "clock": clock(v)}
    out.update(seconds=time.perf_counter() - started, machine=platform.platform())
    print(json.dumps({k: out[k] for k in ("velocity_level", "windows", "vote", "clock")},
                     indent=1))
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    print(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
