"""Carrier-smoothed code: the Hatch filter with cycle-slip detection.

`smooth_observations` replaces every pseudorange of an observation table that has a
carrier phase on the same signal by its carrier-smoothed value (Hatch 1982)::

    P̃_k = P_k / n + (n - 1) / n · (P̃_{k-1} + λ (L_k - L_{k-1})),   n = min(n + 1, N)

with ``N = window_s / interval``: the code's noise and multipath average down over up to
N epochs while the carrier carries the range change. The smoothing restarts (n = 1) on a
**cycle slip** or anything that breaks the carrier's continuity:

* the loss-of-lock indicator (LLI bit 0, RINEX 3.04 §5.3);
* a gap longer than `SmoothingConfig.max_gap_s`, or a missing carrier;
* the **geometry-free** combination ``L1 λ1 - L2 λ2`` (m) jumping by more than
  ``gf_jump_m`` between epochs (ionosphere and phase multipath change by mm-cm per
  second; a one-cycle slip on GPS L1 moves it by 0.19 m, on L2 by 0.24 m; slips on both
  frequencies that nearly cancel are left to the next test);
* the **Melbourne-Wübbena** combination (wide-lane phase minus narrow-lane code, in
  wide-lane cycles) leaving its running mean by more than ``mw_jump_cycles``;
* single frequency: the carrier step ``ΔL`` disagreeing with the Doppler ``-D̄ Δt``
  (RINEX: range rate = -λ D) by more than ``doppler_jump_cycles``;
* the code leaving the smoothed prediction by more than ``max_code_carrier_m``.

The dual-frequency tests use, per satellite and epoch, the first signal with a carrier of
`gnss_obs.measurements.PRIMARY_SIGNALS` and of `SECONDARY_SIGNALS`; a slip they find
restarts every signal of that satellite. A single-frequency Hatch filter also averages
the ionosphere's code-carrier divergence (2 dI/dt): over 100 s at mid latitudes a few dm.

References: R. Hatch, "The synergism of GPS code and carrier measurements", 1982;
RTKLIB rtkpos.c (detslp_ll, detslp_gf, detslp_dop); Teunissen & Montenbruck (eds.),
Springer Handbook of GNSS, 2017, §20.2 (cycle-slip detection).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
import pandas as pd

from gnss_obs.constants import SPEED_OF_LIGHT_MPS, carrier_frequency_hz
from gnss_obs.errors import GnssError
from gnss_obs.measurements import PRIMARY_SIGNALS, SECONDARY_SIGNALS

__all__ = ["SmoothingConfig", "hatch_filter", "slip_flags", "smooth_observations"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]
_LLI_LOST_LOCK = 1


@dataclass(frozen=True)
class SmoothingConfig:
    """Hatch filter settings (module docstring).

    Parameters
    ----------
    window_s : float
        Longest averaging length, s (N = window / epoch interval).
    max_gap_s : float
        A larger step between epochs of a signal restarts it, s.
    gf_jump_m : float
        Geometry-free jump threshold, m.
    mw_jump_cycles : float
        Melbourne-Wübbena threshold from its running mean, wide-lane cycles.
    doppler_jump_cycles : float
        Carrier step minus Doppler prediction threshold, cycles.
    max_code_carrier_m : float
        Code minus smoothed prediction threshold, m.
    """

    window_s: float = 100.0
    max_gap_s: float = 2.5
    gf_jump_m: float = 0.05
    mw_jump_cycles: float = 4.0
    doppler_jump_cycles: float = 3.0
    max_code_carrier_m: float = 30.0

    def __post_init__(self) -> None:
        for name in ("window_s", "max_gap_s", "gf_jump_m", "mw_jump_cycles",
                     "doppler_jump_cycles", "max_code_carrier_m"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise GnssError(f"{name} must be a finite number > 0, got {value!r}")


def hatch_filter(pseudorange_m: Array, carrier_m: Array, restart: npt.NDArray[np.bool_], *,
                 n_max: int, max_code_carrier_m: float = np.inf) -> tuple[Array, Array]:
    """Hatch recursion over one signal's epochs.

    Parameters
    ----------
    pseudorange_m, carrier_m : ndarray, shape (K,)
        Code and carrier phase (cycles × wavelength) in time order, m; NaN carrier
        restarts and passes the code through.
    restart : ndarray of bool, shape (K,)
        Epochs where the carrier is not continuous with the previous one.
    n_max : int
        Largest averaging count N.
    max_code_carrier_m : float
        Restart when the code leaves the carrier-propagated value by more, m.

    Returns
    -------
    smoothed_m : ndarray, shape (K,)
        Smoothed code (NaN where the code is NaN), m.
    count : ndarray, shape (K,)
        Averaging count n at each epoch (0 where no code).
    """
    k_len = len(pseudorange_m)
    out = np.full(k_len, np.nan)
    count = np.zeros(k_len)
    prev_s = prev_l = np.nan
    n = 0
    for k in range(k_len):
        p, lc = pseudorange_m[k], carrier_m[k]
        if not np.isfinite(p):
            n, prev_s, prev_l = 0, np.nan, lc
            continue
        if n == 0 or restart[k] or not (np.isfinite(lc) and np.isfinite(prev_l)):
            n, s = 1, p
        else:
            predicted = prev_s + (lc - prev_l)
            if abs(p - predicted) > max_code_carrier_m:
                n, s = 1, p
            else:
                n = min(n + 1, n_max)
                s = p / n + (n - 1) / n * predicted
        out[k], count[k] = s, n
        prev_s, prev_l = s, lc
    return out, count


def _wavelengths(table: pd.DataFrame, channels: dict[str, int]) -> Array:
    out = np.full(len(table), np.nan)
    keys = table[["sv", "system", "band"]].drop_duplicates()
    lam = {}
    for sv, system, band in keys.itertuples(index=False):
        try:
            lam[(sv, band)] = SPEED_OF_LIGHT_MPS / carrier_frequency_hz(system, int(band),
                                                                        channels.get(sv))
        except KeyError:
            continue
    for i, (sv, band) in enumerate(zip(table["sv"].to_numpy(), table["band"].to_numpy())):
        out[i] = lam.get((sv, band), np.nan)
    return out


def _pick(table: pd.DataFrame, preferences: dict[str, tuple[str, ...]]) -> pd.DataFrame:
    """Per (epoch, satellite) the most preferred signal that has both code and carrier."""
    rank = np.full(len(table), np.inf)
    for s, codes in preferences.items():
        for k, code in enumerate(codes):
            rank[(table["system"].to_numpy() == s) & (table["signal"].to_numpy() == code)] = k
    ok = np.isfinite(rank) & table[["pseudorange_m", "carrier_m"]].notna().all(axis=1).to_numpy()
    rows = table.loc[ok].assign(_rank=rank[ok]).sort_values(["gps_time_s", "sv", "_rank"])
    return rows.drop_duplicates(["gps_time_s", "sv"])


def slip_flags(table: pd.DataFrame, config: SmoothingConfig) -> pd.Series:
    """Dual-frequency (GF, MW) slips per (gps_time_s, sv): a boolean Series on that index.

    `table` is an observation table with ``carrier_m`` (cycles × wavelength) and
    ``wavelength_m`` columns added.
    """
    one, two = _pick(table, PRIMARY_SIGNALS), _pick(table, SECONDARY_SIGNALS)
    pair = one.merge(two, on=["gps_time_s", "sv"], suffixes=("_1", "_2"))
    if pair.empty:
        return pd.Series(dtype=bool)
    pair = pair.sort_values(["sv", "gps_time_s"])
    f1 = SPEED_OF_LIGHT_MPS / pair["wavelength_m_1"].to_numpy()
    f2 = SPEED_OF_LIGHT_MPS / pair["wavelength_m_2"].to_numpy()
    l1, l2 = pair["carrier_m_1"].to_numpy(), pair["carrier_m_2"].to_numpy()
    p1, p2 = pair["pseudorange_m_1"].to_numpy(), pair["pseudorange_m_2"].to_numpy()
    gf = l1 - l2
    lam_wl = SPEED_OF_LIGHT_MPS / (f1 - f2)
    mw = ((f1 * l1 - f2 * l2) / (f1 - f2) - (f1 * p1 + f2 * p2) / (f1 + f2)) / lam_wl
    sv, t = pair["sv"].to_numpy(), pair["gps_time_s"].to_numpy()
    flag = np.zeros(len(pair), dtype=bool)
    mean, n = np.nan, 0
    for k in range(len(pair)):
        new_arc = k == 0 or sv[k] != sv[k - 1] or t[k] - t[k - 1] > config.max_gap_s
        if not new_arc and (abs(gf[k] - gf[k - 1]) > config.gf_jump_m
                            or abs(mw[k] - mean) > config.mw_jump_cycles):
            flag[k] = True
        if new_arc or flag[k]:
            mean, n = mw[k], 1
        else:
            n += 1
            mean += (mw[k] - mean) / n
    return pd.Series(flag, index=pd.MultiIndex.from_arrays([t, sv], names=["gps_time_s", "sv"]))


def _restarts(g: pd.DataFrame, config: SmoothingConfig) -> npt.NDArray[np.bool_]:
    """Single-signal restart conditions (LLI, gap, Doppler) of one (sv, signal) series."""
    t = g["gps_time_s"].to_numpy()
    dt = np.diff(t, prepend=-np.inf)
    restart = ((g["lli"].to_numpy() & _LLI_LOST_LOCK) > 0) | (dt > config.max_gap_s)
    cycles = g["carrier_cycles"].to_numpy()
    doppler = g["doppler_hz"].to_numpy()
    step = np.diff(cycles, prepend=np.nan)
    predicted = -0.5 * (doppler + np.roll(doppler, 1)) * dt
    misfit = np.abs(step - predicted)
    restart |= np.isfinite(misfit) & (misfit > config.doppler_jump_cycles)
    return restart


def smooth_observations(obs, config: SmoothingConfig | None = None, *,
                        glonass_channels: dict[str, int] | None = None):
    """Carrier-smooth every code of an observation file that has a carrier (module docstring).

    Parameters
    ----------
    obs : RinexObs
        `read_rinex_obs` output.
    config : SmoothingConfig, optional
    glonass_channels : dict of str to int, optional
        GLONASS FDMA channel per satellite (default: the header's ``GLONASS SLOT / FRQ #``);
        GLONASS signals without a channel stay unsmoothed.

    Returns
    -------
    RinexObs
        The same file with ``pseudorange_m`` smoothed where a carrier exists (other
        columns unchanged).
    """
    cfg = config or SmoothingConfig()
    channels = dict(obs.header.glonass_slots)
    channels.update(glonass_channels or {})
    table = obs.table.copy()
    table["wavelength_m"] = _wavelengths(table, channels)
    table["carrier_m"] = table["carrier_cycles"].to_numpy() * table["wavelength_m"].to_numpy()
    dual = slip_flags(table, cfg)
    times = np.unique(table["gps_time_s"].to_numpy())
    interval = float(np.median(np.diff(times))) if times.size > 1 else 1.0
    n_max = max(1, int(round(cfg.window_s / interval)))
    smoothed = table["pseudorange_m"].to_numpy().copy()
    n_restarts = 0
    usable = table["carrier_m"].notna() & table["pseudorange_m"].notna()
    for _, g in table[usable].sort_values("gps_time_s").groupby(["sv", "signal"], sort=False):
        restart = _restarts(g, cfg)
        if len(dual):
            keys = pd.MultiIndex.from_arrays([g["gps_time_s"], g["sv"]])
            restart |= dual.reindex(keys, fill_value=False).to_numpy(dtype=bool)
        s, count = hatch_filter(g["pseudorange_m"].to_numpy(), g["carrier_m"].to_numpy(),
                                restart, n_max=n_max, max_code_carrier_m=cfg.max_code_carrier_m)
        smoothed[table.index.get_indexer(g.index)] = s
        n_restarts += int(np.sum(count == 1)) - 1
    log.info("Hatch smoothing over %.0f s: %d restarts (slips, gaps) on %d signals",
             cfg.window_s, n_restarts, table[usable].groupby(["sv", "signal"]).ngroups)
    out = obs.table.copy()
    out["pseudorange_m"] = smoothed
    return replace(obs, table=out)
