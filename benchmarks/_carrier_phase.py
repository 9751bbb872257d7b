"""Time-differenced carrier phase of the rover (TDCP) for the benchmarks on the urban
drive: the carrier's range rate per satellite and the receiver's displacement over each
second (``bench_doppler_carrier.py`` holds the method and what it found).
"""
from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from gnss_obs.constants import SPEED_OF_LIGHT_MPS
from gnss_obs.epoch import prepare_epoch, split_epochs
from gnss_obs.measurements import MeasurementConfig, select_measurements

__all__ = ["carrier_rates", "tdcp", "L1_HZ", "SIGNALS"]

L1_HZ = 1575.42e6
#: Signals compared at the observation level: (system, RINEX code) -> carrier frequency, Hz.
SIGNALS = {("G", "1C"): L1_HZ, ("G", "2L"): 1227.60e6, ("G", "5Q"): 1176.45e6,
           ("E", "1C"): L1_HZ, ("E", "5Q"): 1176.45e6, ("E", "7Q"): 1207.14e6,
           ("C", "2I"): 1561.098e6}
#: A carrier step further than this from the Doppler is a cycle slip, m/s.
SLIP_MPS = 1.0
TDCP_MAX_RESIDUAL_M = 0.05
TDCP_MIN_SATS = 5
#: Most satellites a second's solution may leave out (every subset is tried), and how far
#: (m, in the second's displacement) two consistent subsets of the same size may disagree
#: before the second is dropped as ambiguous.
TDCP_MAX_REMOVED = 3
TDCP_AMBIGUOUS_M = 0.05
TDCP_MIN_ELEVATION_RAD = np.radians(10.0)


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
    """The largest subset of satellites (at least `TDCP_MIN_SATS`, at most
    `TDCP_MAX_REMOVED` left out) whose residuals are all within `TDCP_MAX_RESIDUAL_M`:
    ``(x, residual RMS, satellites)``; None if there is none, or if two such subsets
    disagree by more than `TDCP_AMBIGUOUS_M` (a greedy removal of the largest residual
    can keep the wrong satellites when few are left)."""
    n = y.size
    for removed in range(min(TDCP_MAX_REMOVED, n - TDCP_MIN_SATS) + 1):
        found = []
        for out in itertools.combinations(range(n), removed):
            keep = np.ones(n, dtype=bool)
            keep[list(out)] = False
            x, *_ = np.linalg.lstsq(H[keep], y[keep], rcond=None)
            res = np.abs(y[keep] - H[keep] @ x)
            if res.max() <= TDCP_MAX_RESIDUAL_M:
                found.append((x, float(np.sqrt(np.mean(res ** 2))), int(keep.sum())))
        if found:
            spread = max(np.linalg.norm(f[0][:3] - found[0][0][:3]) for f in found)
            return min(found, key=lambda f: f[1]) if spread <= TDCP_AMBIGUOUS_M else None
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
