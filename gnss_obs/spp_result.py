"""Results of the single-point positioning: per-epoch fixes and the ``spp.csv`` table.

`SppResult.to_frame()` gives the columns the ``railnav spp`` command writes (units in the
names, ARCHITECTURE.md "The command line"):

``gps_time_s, lat_deg, lon_deg, h_m, v_east_mps, v_north_mps, v_up_mps,
clock_bias_<S>_m`` (receiver clock seen by system S, m, one column per configured system)
``, clock_drift_mps, n_sat_tracked, n_sat_used, n_sat_doppler, gdop, pdop, hdop, vdop, tdop,
sigma_east_m, sigma_north_m, sigma_up_m, sigma_v_east_mps, sigma_v_north_mps,
sigma_v_up_mps, hpl_m, vpl_m, chi2, dof, chi2_doppler, dof_doppler, fix_ok, raim_ok,
velocity_ok, n_excluded, excluded_sv``.

``chi2``/``dof`` are the weighted sum of squared pseudorange residuals and its degrees of
freedom (``chi2_doppler``/``dof_doppler`` for the range rates): ``chi2/dof`` near 1 means the
σ model fits. Flags: ``fix_ok`` a position was computed; ``raim_ok`` its χ² residual test passed
(after any exclusion); ``velocity_ok`` a Doppler velocity was computed and its test passed;
``excluded_sv`` the satellites removed by FDE (space-separated).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import pandas as pd

from gnss_obs.dop import Dop
from trackmodel.earth import C_n_e, ecef_to_geodetic

__all__ = ["EpochFix", "SppResult", "assemble_result", "SATELLITE_COLUMNS"]

Array = npt.NDArray[np.float64]

#: Columns of `SppResult.satellites`.
SATELLITE_COLUMNS = ["gps_time_s", "sv", "system", "elevation_deg", "azimuth_deg", "cn0_dbhz",
                     "pr_residual_m", "used", "excluded", "used_doppler"]


@dataclass
class EpochFix:
    """One epoch's solution (internal record of `solve_spp`; arrays in SI, ECEF)."""

    gps_time_s: float
    r_e: Array
    cov_enu: Array
    clocks: dict[str, float]
    used_sv: np.ndarray
    excluded_sv: list[str]
    n_tracked: int
    raim_ok: bool
    chi2: float
    dof: int
    hpl_m: float
    vpl_m: float
    dop: Dop
    sky: dict
    v_e: Array = field(default_factory=lambda: np.full(3, np.nan))
    clock_drift_mps: float = float("nan")
    cov_v_enu: Array = field(default_factory=lambda: np.full((3, 3), np.nan))
    doppler_sv: np.ndarray = field(default_factory=lambda: np.array([], dtype=object))
    velocity_raim_ok: bool = False
    chi2_doppler: float = float("nan")
    dof_doppler: int = 0
    #: The position's last linearized problem with every usable satellite, before any
    #: exclusion: design ``H``, pre-fit residuals ``z`` (m) and told σ (m)
    #: (`railnav.navigation.spp_epochs`' noise scale).
    pr_rows: tuple | None = None


@dataclass(frozen=True)
class SppResult:
    """Per-epoch SPP solutions (M epochs) and per-satellite details.

    Attributes
    ----------
    gps_time_s : ndarray, shape (M,)
        Epoch, s since the GPS epoch.
    systems : str
        Configured systems (order of the clock columns).
    r_e : ndarray, shape (M, 3)
        Position, ECEF, m (NaN without a fix).
    v_e : ndarray, shape (M, 3)
        Velocity, ECEF, m/s (NaN without a velocity).
    clock_bias_m : dict of str to ndarray, shape (M,)
        Receiver clock bias seen by each system, m.
    clock_drift_mps : ndarray, shape (M,)
        Receiver clock drift, m/s.
    cov_enu_m2 : ndarray, shape (M, 3, 3)
        Position covariance in ENU, m².
    cov_v_enu_m2ps2 : ndarray, shape (M, 3, 3)
        Velocity covariance in ENU, (m/s)².
    table : pandas.DataFrame
        The remaining per-epoch columns of `to_frame` (counts, DOPs, levels, flags).
    satellites : pandas.DataFrame
        `SATELLITE_COLUMNS`: every tracked satellite of every fixed epoch, with look angles,
        pseudorange residual at the fix and whether it was used/excluded.
    n_no_fix : int
        Epochs without a position.
    """

    gps_time_s: Array
    systems: str
    r_e: Array
    v_e: Array
    clock_bias_m: dict[str, Array]
    clock_drift_mps: Array
    cov_enu_m2: Array
    cov_v_enu_m2ps2: Array
    table: pd.DataFrame
    satellites: pd.DataFrame
    n_no_fix: int

    def to_frame(self) -> pd.DataFrame:
        """The ``spp.csv`` table (module docstring), one row per epoch."""
        lat, lon, h = ecef_to_geodetic(self.r_e)
        v_n = np.einsum("nji,nj->ni", C_n_e(lat, lon), self.v_e)
        sig = np.sqrt(np.diagonal(self.cov_enu_m2, axis1=1, axis2=2))
        sig_v = np.sqrt(np.diagonal(self.cov_v_enu_m2ps2, axis1=1, axis2=2))
        cols = {"gps_time_s": self.gps_time_s, "lat_deg": np.rad2deg(lat),
                "lon_deg": np.rad2deg(lon), "h_m": h, "v_east_mps": v_n[:, 0],
                "v_north_mps": v_n[:, 1], "v_up_mps": v_n[:, 2]}
        cols.update({f"clock_bias_{s}_m": self.clock_bias_m[s] for s in self.systems})
        cols["clock_drift_mps"] = self.clock_drift_mps
        head = pd.DataFrame(cols)
        sigmas = pd.DataFrame({
            "sigma_east_m": sig[:, 0], "sigma_north_m": sig[:, 1], "sigma_up_m": sig[:, 2],
            "sigma_v_east_mps": sig_v[:, 0], "sigma_v_north_mps": sig_v[:, 1],
            "sigma_v_up_mps": sig_v[:, 2]})
        counts = self.table[["n_sat_tracked", "n_sat_used", "n_sat_doppler", "gdop", "pdop",
                             "hdop", "vdop", "tdop"]]
        flags = self.table[["hpl_m", "vpl_m", "chi2", "dof", "chi2_doppler", "dof_doppler",
                            "fix_ok", "raim_ok", "velocity_ok", "n_excluded", "excluded_sv"]]
        return pd.concat([head, counts.reset_index(drop=True), sigmas,
                          flags.reset_index(drop=True)], axis=1)


def _epoch_row(fix: EpochFix | None, n_tracked: int) -> dict:
    if fix is None:
        return {"n_sat_tracked": n_tracked, "n_sat_used": 0, "n_sat_doppler": 0,
                **{k: np.nan for k in ("gdop", "pdop", "hdop", "vdop", "tdop", "hpl_m",
                                       "vpl_m")},
                "fix_ok": False, "raim_ok": False, "velocity_ok": False, "n_excluded": 0,
                "excluded_sv": "", "chi2": np.nan, "dof": 0, "chi2_doppler": np.nan,
                "dof_doppler": 0}
    d = fix.dop
    return {"n_sat_tracked": fix.n_tracked, "n_sat_used": len(fix.used_sv),
            "n_sat_doppler": len(fix.doppler_sv), "gdop": d.gdop, "pdop": d.pdop,
            "hdop": d.hdop, "vdop": d.vdop, "tdop": d.tdop, "hpl_m": fix.hpl_m,
            "vpl_m": fix.vpl_m, "fix_ok": True, "raim_ok": fix.raim_ok,
            "velocity_ok": bool(np.all(np.isfinite(fix.v_e)) and fix.velocity_raim_ok),
            "n_excluded": len(fix.excluded_sv), "excluded_sv": " ".join(fix.excluded_sv),
            "chi2": fix.chi2, "dof": fix.dof, "chi2_doppler": fix.chi2_doppler,
            "dof_doppler": fix.dof_doppler}


def _satellite_frame(fixes: list[EpochFix | None]) -> pd.DataFrame:
    parts = []
    for fix in fixes:
        if fix is None:
            continue
        sky = fix.sky
        parts.append(pd.DataFrame({
            "gps_time_s": fix.gps_time_s, "sv": sky["sv"], "system": sky["system"],
            "elevation_deg": np.rad2deg(sky["elevation"]),
            "azimuth_deg": np.rad2deg(sky["azimuth"]), "cn0_dbhz": sky["cn0_dbhz"],
            "pr_residual_m": sky["pr_residual_m"], "used": np.isin(sky["sv"], fix.used_sv),
            "excluded": np.isin(sky["sv"], fix.excluded_sv),
            "used_doppler": np.isin(sky["sv"], fix.doppler_sv)}))
    if not parts:
        return pd.DataFrame({c: [] for c in SATELLITE_COLUMNS})
    return pd.concat(parts, ignore_index=True)[SATELLITE_COLUMNS]


def assemble_result(epochs, fixes: list[EpochFix | None], systems: str) -> SppResult:
    """Stack per-epoch fixes (None = no fix) into an `SppResult`."""
    m = len(epochs)
    nan3 = np.full(3, np.nan)
    nan33 = np.full((3, 3), np.nan)
    ok = [f is not None for f in fixes]
    r_e = np.array([f.r_e if f is not None else nan3 for f in fixes]).reshape(m, 3)
    v_e = np.array([f.v_e if f is not None else nan3 for f in fixes]).reshape(m, 3)
    table = pd.DataFrame([_epoch_row(f, len(e)) for f, e in zip(fixes, epochs)])
    return SppResult(
        gps_time_s=np.array([e.gps_time_s for e in epochs], dtype=float),
        systems=systems, r_e=r_e, v_e=v_e,
        clock_bias_m={s: np.array([f.clocks.get(s, np.nan) if f is not None else np.nan
                                   for f in fixes]) for s in systems},
        clock_drift_mps=np.array([f.clock_drift_mps if f is not None else np.nan
                                  for f in fixes]),
        cov_enu_m2=np.array([f.cov_enu if f is not None else nan33 for f in fixes]
                            ).reshape(m, 3, 3),
        cov_v_enu_m2ps2=np.array([f.cov_v_enu if f is not None else nan33 for f in fixes]
                                 ).reshape(m, 3, 3),
        table=table, satellites=_satellite_frame(fixes), n_no_fix=int(m - sum(ok)))
