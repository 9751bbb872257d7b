"""Simulated GNSS measurements for any receiver trajectory, as a RINEX observation table.

`simulate_gnss` takes the constellation of a broadcast navigation file (the real geometry of
its day; by default the shipped 2020-11-29 file, `default_nav_path`) and a receiver
trajectory, and generates per epoch and visible satellite:

``P  = ρ + b - c(δt_sv - T_GD) + I + T + m + f + ε_P``
``ρ̇ = e·(v_sat - v_rx) + d - c δṫ_sv + ε_ρ̇``,  written as Doppler ``D = -ρ̇ / λ``

* ``ρ``: geometric range from an **independent** NumPy light-time iteration (not the
  CasADi models of `gnss_obs.observables`, not the pseudorange-based transmission time of
  `gnss_obs.epoch`): ``τ = |r_sat(t_r - τ) - R_z(-Ωτ) r_rx| / c`` solved by fixed point,
  the receiver turned into the ECEF frame of the transmission instant;
* ``b, d``: receiver clock (`gnss_obs.oscillator`; time tags are receiver time, so the true
  reception time is ``t_r = t_tag - b/c``; the receiver position is the trajectory's at the
  tag, an error of ``|v| b / c``, below 1 mm while ``|b| < 15 km`` at 20 m/s);
* ``δt_sv, T_GD``: broadcast satellite clock with relativity and the signal's group delay
  (`gnss_obs.ephemeris`);
* ``I, T``: Klobuchar and Saastamoinen/Niell delays from **the same functions the
  estimators use** (`gnss_obs.corrections`) at the true position: an estimator applying its
  corrections at its estimate removes them exactly (to the small change of the delays with
  the position error). The simulation tests estimators, not atmosphere models;
* ``m``: optional multipath, a first-order Gauss-Markov bias per satellite;
* ``f``: optional per-satellite faults (step and/or ramp from a start time);
* ``ε``: white Gaussian noise, σ constant or ``σ / sin(elevation)``.

Satellites below the elevation mask are not observed; **outages** remove all satellites or
keep only the N highest, or raise the mask, inside time windows. One signal per system:
GPS/QZSS L1 C/A ``1C``, Galileo E1 ``1C`` (I/NAV clock), BeiDou B1I ``2I``, GLONASS L1 ``1C``.
Pseudoranges, Doppler and C/N0 are rounded to the RINEX resolution (0.001) so that a table
written with `write_rinex_obs` reads back identically.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pandas as pd
from railnav_data import GNSS, shipped_path

from gnss_obs.constants import (
    OMEGA_E_GPS,
    SPEED_OF_LIGHT_MPS,
    carrier_frequency_hz,
)
from gnss_obs.corrections import (
    ionosphere_scale,
    klobuchar_delay_s,
    look_angles,
    troposphere_delay_m,
)
from gnss_obs.ephemeris import group_delay_s, satellite_states, select_ephemeris, take_rows
from gnss_obs.errors import GnssError, GnssInputError
from gnss_obs.oscillator import oscillator_from_name, simulate_clock
from gnss_obs.rinex_nav import RinexNav, read_rinex_nav
from gnss_obs.rinex_obs import RinexObs
from gnss_obs.sim_defaults import (
    DEFAULT_START_GPS_TIME_S,
    PAPER_SIGMA_PR_M,
    PAPER_SIGMA_RR_MPS,
)
from gnss_obs.sim_events import (
    Outage,
    SatelliteFault,
    apply_faults,
    visible_after_outages,
)
from gnss_obs.sim_files import simulation_header, write_simulation
from gnss_obs.sim_result import GnssSimulation
from trackmodel.earth import ecef_to_geodetic

__all__ = ["GnssSimConfig", "GnssSimulation", "SatelliteFault", "Outage", "simulate_gnss",
           "write_simulation", "default_nav_path", "SIM_SIGNALS", "DEFAULT_START_GPS_TIME_S",
           "PAPER_SIGMA_PR_M", "PAPER_SIGMA_RR_MPS"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

#: Simulated signal per system: (RINEX signal, band).
SIM_SIGNALS = {"G": ("1C", 1), "E": ("1C", 1), "C": ("2I", 2), "R": ("1C", 1), "J": ("1C", 1)}
_RINEX_DECIMALS = 3
_LIGHT_TIME_ITERATIONS = 6
_LIGHT_TIME_TOL_S = 1e-13
_NOMINAL_FLIGHT_S = 0.075


def _time_origin(cfg: "GnssSimConfig", gps_time_s: Array) -> float:
    """GPS time (s) from which the faults' and outages' times count."""
    if cfg.time_origin_gps_time_s is None:
        return float(gps_time_s[0])
    return float(cfg.time_origin_gps_time_s)


def default_nav_path() -> Path:
    """The shipped broadcast navigation file (``data/gnss/broadcast_nav.rnx``, 2020-11-29),
    found in the installed data (`railnav_data`); raises `GnssError` if it is missing.
    """
    path = shipped_path(GNSS, "broadcast_nav.rnx")
    if not path.is_file():
        raise GnssError(f"default navigation file not found at {path}; pass a RinexNav")
    return path


@dataclass(frozen=True)
class GnssSimConfig:
    """Settings of the measurement generator (module docstring).

    Parameters
    ----------
    systems : str
        Systems to simulate (letters of ``GECRJ``).
    elevation_mask_deg : float
        Satellites below are not observed, deg.
    sigma_pr_m, sigma_rr_mps : float
        White-noise standard deviations of pseudorange (m) and range rate (m/s) at zenith
        (defaults: the 2017 paper's scenario, elevation-independent).
    elevation_dependent_noise : bool
        Scale σ by ``1/sin(elevation)``.
    multipath_sigma_m : float
        Steady-state σ of the multipath bias (0 = none), m; scaled by ``1/sin(elevation)``.
    multipath_tau_s : float
        Correlation time of the multipath bias, s.
    oscillator : str
        Receiver clock preset (`gnss_obs.oscillator.OSCILLATORS`).
    clock_bias0_m, clock_drift0_mps : float
        Receiver clock bias (m) and drift (m/s) at the first epoch.
    ionosphere, troposphere : bool
        Add the Klobuchar and Saastamoinen/Niell delays.
    cn0_zenith_dbhz, cn0_horizon_dbhz : float
        C/N0 written to the file, linear in sin(elevation) between these.
    faults : tuple of SatelliteFault
    outages : tuple of Outage
    time_origin_gps_time_s : float or None
        GPS time (s) from which the faults' and outages' times count: the trip start;
        None: the first epoch simulated.
    """

    systems: str = "GE"
    elevation_mask_deg: float = 10.0
    sigma_pr_m: float = PAPER_SIGMA_PR_M
    sigma_rr_mps: float = PAPER_SIGMA_RR_MPS
    elevation_dependent_noise: bool = False
    multipath_sigma_m: float = 0.0
    multipath_tau_s: float = 60.0
    oscillator: str = "tcxo"
    clock_bias0_m: float = 0.0
    clock_drift0_mps: float = 0.0
    ionosphere: bool = True
    troposphere: bool = True
    cn0_zenith_dbhz: float = 48.0
    cn0_horizon_dbhz: float = 36.0
    faults: tuple[SatelliteFault, ...] = ()
    outages: tuple[Outage, ...] = ()
    time_origin_gps_time_s: float | None = None

    def __post_init__(self) -> None:
        if not self.systems or set(self.systems) - set(SIM_SIGNALS):
            raise GnssError(f"systems must be letters of {''.join(SIM_SIGNALS)}, "
                            f"got {self.systems!r}")
        for name in ("sigma_pr_m", "sigma_rr_mps", "multipath_sigma_m"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise GnssError(f"{name} must be a finite number >= 0, got {v!r}")
        if not (self.multipath_tau_s > 0):
            raise GnssError("multipath_tau_s must be > 0")
        if not (-90.0 <= self.elevation_mask_deg < 90.0):
            raise GnssError("elevation_mask_deg must be in [-90, 90)")
        oscillator_from_name(self.oscillator)


def _check_trajectory(t: Array, r_e: Array, v_e: Array) -> None:
    if t.ndim != 1 or t.size == 0 or not np.all(np.isfinite(t)):
        raise GnssInputError("gps_time_s must be a non-empty 1-D array of finite times",
                             column="gps_time_s")
    if np.any(np.diff(t) <= 0):
        raise GnssInputError("gps_time_s must be strictly increasing", column="gps_time_s")
    for name, a in (("r_e", r_e), ("v_e", v_e)):
        if a.shape != (t.size, 3) or not np.all(np.isfinite(a)):
            raise GnssInputError(f"{name} must be a finite array of shape ({t.size}, 3), "
                                 f"got {a.shape}", column=name)


def _candidate_satellites(nav: RinexNav, systems: str) -> list[str]:
    out = []
    for s in systems:
        recs = nav.records.get(s)
        if recs is not None and len(recs):
            out += sorted(set(recs.loc[recs["health"] == 0, "sv"]))
    if not out:
        raise GnssError(f"the navigation data has no healthy records of systems {systems!r}")
    return out


def _light_time(sel: dict[str, np.ndarray], t_rx: Array, r_rx: Array):
    """Fixed-point light time with the receiver turned into the transmission-time frame
    (`sel`: the selected records' columns, `gnss_obs.ephemeris.take_rows`)."""
    tau = np.full(t_rx.shape, _NOMINAL_FLIGHT_S)
    for _ in range(_LIGHT_TIME_ITERATIONS):
        states = satellite_states(sel, t_rx - tau)
        a = OMEGA_E_GPS * tau  # Earth rotation during the flight
        c, s = np.cos(a), np.sin(a)
        rx_tx = np.stack([c * r_rx[:, 0] - s * r_rx[:, 1], s * r_rx[:, 0] + c * r_rx[:, 1],
                          r_rx[:, 2]], axis=-1)
        new_tau = np.linalg.norm(states.r_e - rx_tx, axis=1) / SPEED_OF_LIGHT_MPS
        done = np.max(np.abs(new_tau - tau), initial=0.0) < _LIGHT_TIME_TOL_S
        tau = new_tau
        if done:
            break
    return states, tau, a, rx_tx


def _rotate_into_tx_frame(vec: Array, angle: Array) -> Array:
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * vec[:, 0] - s * vec[:, 1], s * vec[:, 0] + c * vec[:, 1], vec[:, 2]],
                    axis=-1)


def _multipath(sv: np.ndarray, epoch: np.ndarray, t: Array, elevation: Array,
               cfg: GnssSimConfig, rng: np.random.Generator) -> Array:
    """First-order Gauss-Markov bias per satellite over the epoch grid, times 1/sin(el)."""
    out = np.zeros(sv.size)
    if cfg.multipath_sigma_m == 0:
        return out
    names, col = np.unique(sv, return_inverse=True)
    grid = np.zeros((t.size, names.size))
    grid[0] = cfg.multipath_sigma_m * rng.standard_normal(names.size)
    phi = np.exp(-np.diff(t) / cfg.multipath_tau_s)
    w = rng.standard_normal((t.size - 1, names.size))
    for k in range(t.size - 1):
        grid[k + 1] = phi[k] * grid[k] + cfg.multipath_sigma_m * np.sqrt(1 - phi[k] ** 2) * w[k]
    return grid[epoch, col] / np.sin(np.maximum(elevation, np.deg2rad(5.0)))


def simulate_gnss(gps_time_s: npt.ArrayLike, r_e: npt.ArrayLike, v_e: npt.ArrayLike,
                  nav: RinexNav | None = None, config: GnssSimConfig | None = None, *,
                  rng: np.random.Generator) -> GnssSimulation:
    """Simulate pseudorange and Doppler observations of a receiver trajectory.

    Parameters
    ----------
    gps_time_s : array_like, shape (N,)
        Epoch time tags (receiver time), s since the GPS epoch; inside the validity of
        `nav` (the shipped file: 2020-11-29 10:00-15:00 GPST, see
        `DEFAULT_START_GPS_TIME_S`).
    r_e : array_like, shape (N, 3)
        Receiver (antenna) position, ECEF, m.
    v_e : array_like, shape (N, 3)
        Receiver velocity, ECEF, m/s.
    nav : RinexNav, optional
        Broadcast navigation data (orbits, clocks, Klobuchar coefficients); default: the
        shipped 2020-11-29 file (`default_nav_path`). Write the same data next to the
        observations (`write_simulation`) so that a reader of the files sees this orbit.
    config : GnssSimConfig, optional
    rng : numpy.random.Generator
        Source of every random draw (clock, noise, multipath).

    Returns
    -------
    GnssSimulation
        Observation table + header, receiver clock truth, per-observation truth.

    Raises
    ------
    GnssInputError
        For a trajectory that is not finite, increasing and of matching shapes.
    GnssError
        If the navigation data has no usable satellite of the configured systems.
    """
    cfg = config or GnssSimConfig()
    nav = nav if nav is not None else read_rinex_nav(default_nav_path())
    t = np.asarray(gps_time_s, dtype=float)
    r_e, v_e = np.asarray(r_e, dtype=float), np.asarray(v_e, dtype=float)
    _check_trajectory(t, r_e, v_e)
    bias, drift = simulate_clock(t, oscillator_from_name(cfg.oscillator),
                                 bias0_m=cfg.clock_bias0_m, drift0_mps=cfg.clock_drift0_mps,
                                 rng=rng)
    svs = _candidate_satellites(nav, cfg.systems)
    epoch = np.repeat(np.arange(t.size), len(svs))
    sv = np.tile(np.array(svs, dtype=object), t.size)
    sel = select_ephemeris(nav.records, sv, t[epoch])
    ok = sel["ephemeris_ok"].to_numpy()
    epoch, sv, sel = epoch[ok], sv[ok], sel[ok].reset_index(drop=True)
    geo = _geometry(sel, t, epoch, r_e, v_e, bias)
    keep = visible_after_outages(t, epoch, geo["elevation"], cfg.outages,
                                 mask_rad=np.deg2rad(cfg.elevation_mask_deg),
                                 origin_s=_time_origin(cfg, t))
    if not keep.any():
        raise GnssError("no satellite is observed at any epoch (the outages cover the whole "
                        "trip or the elevation mask hides every satellite); simulate "
                        "without GNSS instead")
    geo = {k: v[keep] for k, v in geo.items()}
    epoch, sv, sel = epoch[keep], sv[keep], sel[keep].reset_index(drop=True)
    return _measurements(t, epoch, sv, sel, geo, r_e, bias, drift, cfg, nav, rng)


def _geometry(sel: pd.DataFrame, t: Array, epoch: np.ndarray, r_e: Array, v_e: Array,
              bias: Array) -> dict[str, Array]:
    """Range, range rate and look angles of every (epoch, satellite) pair."""
    t_rx = t[epoch] - bias[epoch] / SPEED_OF_LIGHT_MPS  # tags are receiver time
    r_rx, v_rx = r_e[epoch], v_e[epoch]
    columns = take_rows(sel, slice(None))   # the table's columns once, not at each iteration
    states, tau, angle, rx_tx = _light_time(columns, t_rx, r_rx)
    los = states.r_e - rx_tx
    geometric = np.linalg.norm(los, axis=1)
    unit = los / geometric[:, None]
    rate = np.einsum("ni,ni->n", unit, states.v_e - _rotate_into_tx_frame(v_rx, angle))
    sat_in_rx_frame = _rotate_into_tx_frame(states.r_e, -angle)
    elevation, azimuth = look_angles(r_rx, sat_in_rx_frame)
    return {"range": geometric, "rate": rate, "elevation": elevation, "azimuth": azimuth,
            "sat_clock_s": states.clock_s, "sat_drift_sps": states.clock_drift_sps}


def _signals(sv: np.ndarray, sel: pd.DataFrame):
    """System letter, RINEX signal, band, carrier frequency (Hz) and PRN of each row,
    looked up once per satellite (and GLONASS channel) rather than row by row."""
    names, row = np.unique(sv.astype(str), return_inverse=True)
    system = np.array([s[0] for s in names], dtype="U1")[row]
    prn = np.array([int(s[1:]) for s in names], dtype=np.int64)[row]
    signal = np.array([SIM_SIGNALS[s[0]][0] for s in names], dtype=object)[row]
    band = np.array([SIM_SIGNALS[s[0]][1] for s in names], dtype=np.int64)[row]
    channel = sel["freq_channel"].to_numpy() if "freq_channel" in sel else np.full(sv.size, np.nan)
    freq = np.empty(sv.size)
    for letter in np.unique(system):
        rows = system == letter
        b = int(SIM_SIGNALS[letter][1])
        if letter == "R":                   # FDMA: the frequency of each channel
            ks, k_row = np.unique(channel[rows], return_inverse=True)
            freq[rows] = np.array([carrier_frequency_hz("R", b, int(k)) for k in ks])[k_row]
        else:
            freq[rows] = carrier_frequency_hz(letter, b, None)
    return system, signal, band, freq, prn


def _atmosphere(t_row: Array, r_rx: Array, geo: dict, freq: Array, cfg: GnssSimConfig,
                nav: RinexNav) -> tuple[Array, Array]:
    lat, lon, h = ecef_to_geodetic(r_rx)
    iono = np.zeros(t_row.size)
    tropo = np.zeros(t_row.size)
    if cfg.ionosphere and nav.header.iono_gps_alpha is not None:
        iono = SPEED_OF_LIGHT_MPS * klobuchar_delay_s(
            nav.header.iono_gps_alpha, nav.header.iono_gps_beta, lat=lat, lon=lon,
            elevation=geo["elevation"], azimuth=geo["azimuth"], gps_time_s=t_row) \
            * ionosphere_scale(freq)
    if cfg.troposphere:
        tropo = troposphere_delay_m(geo["elevation"], lat, h, gps_time_s=t_row)
    return iono, tropo


def _measurements(t, epoch, sv, sel, geo, r_e, bias, drift, cfg: GnssSimConfig,
                  nav: RinexNav, rng: np.random.Generator) -> GnssSimulation:
    system, signal, band, freq, prn = _signals(sv, sel)
    t_row = t[epoch]
    iono, tropo = _atmosphere(t_row, r_e[epoch], geo, freq, cfg, nav)
    clock_m = SPEED_OF_LIGHT_MPS * (geo["sat_clock_s"] - group_delay_s(sel, band))
    pr_free = geo["range"] + bias[epoch] - clock_m + iono + tropo
    rr_free = geo["rate"] + drift[epoch] - SPEED_OF_LIGHT_MPS * geo["sat_drift_sps"]
    scale = 1.0 / np.sin(np.maximum(geo["elevation"], np.deg2rad(5.0))) \
        if cfg.elevation_dependent_noise else np.ones(sv.size)
    noise_pr = cfg.sigma_pr_m * scale * rng.standard_normal(sv.size)
    noise_rr = cfg.sigma_rr_mps * scale * rng.standard_normal(sv.size)
    multipath = _multipath(sv, epoch, t, geo["elevation"], cfg, rng)
    fault_pr, fault_rr = apply_faults(t, epoch, sv, cfg.faults, origin_s=_time_origin(cfg, t))
    pr = pr_free + multipath + fault_pr + noise_pr
    rr = rr_free + fault_rr + noise_rr
    sin_el = np.clip(np.sin(geo["elevation"]), 0.0, 1.0)
    cn0 = cfg.cn0_horizon_dbhz + (cfg.cn0_zenith_dbhz - cfg.cn0_horizon_dbhz) * sin_el
    n = sv.size
    table = pd.DataFrame({
        "gps_time_s": t_row, "sv": sv.astype(object), "system": system.astype(object),
        "prn": prn, "signal": signal,
        "band": band, "pseudorange_m": np.round(pr, _RINEX_DECIMALS),
        "carrier_cycles": np.full(n, np.nan),
        "doppler_hz": np.round(-rr * freq / SPEED_OF_LIGHT_MPS, _RINEX_DECIMALS),
        "cn0_dbhz": np.round(cn0, _RINEX_DECIMALS), "lli": np.zeros(n, dtype=np.int64),
        "ssi": np.zeros(n, dtype=np.int64), "epoch_flag": np.zeros(n, dtype=np.int64)})
    truth = pd.DataFrame({
        "gps_time_s": t_row, "sv": sv, "elevation_deg": np.rad2deg(geo["elevation"]),
        "azimuth_deg": np.rad2deg(geo["azimuth"]), "iono_m": iono, "tropo_m": tropo,
        "multipath_m": multipath, "fault_m": fault_pr, "noise_pr_m": noise_pr,
        "noise_rr_mps": noise_rr, "pseudorange_free_m": pr_free,
        "range_rate_free_mps": rr_free})
    order = np.lexsort((table["sv"].to_numpy().astype(str), t_row))
    table = table.iloc[order].reset_index(drop=True)
    truth = truth.iloc[order].reset_index(drop=True)
    clock = pd.DataFrame({"gps_time_s": t, "clock_bias_m": bias, "clock_drift_mps": drift})
    glo = system == "R"
    slots = {str(s): int(k) for s, k in zip(sv[glo], sel.loc[glo, "freq_channel"])} \
        if glo.any() else {}
    header = simulation_header(table, signals={s: v[0] for s, v in SIM_SIGNALS.items()},
                               r0_e=r_e[0], glonass_slots=slots,
                               leap_seconds=nav.header.leap_seconds)
    return GnssSimulation(RinexObs(header, table), clock, truth)
