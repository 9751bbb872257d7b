"""Single-point positioning from RINEX files: the public API behind ``railnav spp``.

`spp_files` reads the rover observations and the broadcast navigation, applies what is
asked of the augmentation (carrier smoothing, a base station's code corrections, SP3
precise orbits: `gnss_obs.augment`), solves every epoch (`gnss_obs.solve_spp`, RAIM/FDE)
and, with a reference trajectory, computes the errors
(`railnav.evaluation.spp_accuracy`). It returns an `SppRun`, whose `SppRun.write` writes
``spp.csv`` and ``spp.png`` and whose `SppRun.lines` are what the command prints. The
command parses its flags into these arguments and does nothing else, so a notebook calling
``spp_files(obs, nav)`` gets what ``railnav spp --obs OBS --nav NAV`` writes.

Systems: `spp_files` uses railnav's `DEFAULT_SYSTEMS` (``"G"``), as every ``railnav``
command does (``railnav run`` on the same file uses the same satellites). The library's
own default, ``gnss_obs.SppConfig()`` (`gnss_obs.MeasurementConfig.systems`), is
``"GE"``: ``gnss_obs.solve_spp(obs, nav)`` is therefore a different solution from
``spp_files(obs, nav)``; pass ``systems="GE"`` to the one or
``SppConfig(measurement=MeasurementConfig(systems="G"))`` to the other for the same.
"""
from __future__ import annotations

import logging
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from gnss_obs.dgps import augment_files
from gnss_obs.measurements import MeasurementConfig
from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.rinex_obs import read_rinex_obs
from gnss_obs.smoothing import SmoothingConfig
from gnss_obs.spp import solve_spp
from gnss_obs.spp_config import SppConfig
from gnss_obs.spp_result import SppResult
from railnav.defaults import (
    DEFAULT_ELEVATION_MASK_DEG,
    DEFAULT_IONOSPHERE,
    DEFAULT_SYSTEMS,
)
from railnav.evaluation.spp_accuracy import (
    SppAccuracy,
    accuracy_summary,
    plot_spp,
    read_reference_trajectory,
    spp_errors,
)
from trackmodel.files import atomic_write_csv

__all__ = ["SppRun", "spp_files", "spp_config", "FLOAT_FORMAT", "TIME_FORMAT"]

log = logging.getLogger(__name__)

#: ``spp.csv`` float format: 12 significant digits (0.1 mm in ECEF-sized numbers,
#: 1e-10 deg).
FLOAT_FORMAT = "%.12g"
#: ``gps_time_s`` is written with 6 decimals (1 µs): 12 significant digits of a GPS time
#: (~1.3e9 s) would be 10 ms, coarser than receivers' sub-ms epoch offsets (issue 16).
TIME_FORMAT = "{:.6f}"


@dataclass(frozen=True, eq=False)
class SppRun:
    """A finished `spp_files` run.

    Attributes
    ----------
    frame : pandas.DataFrame
        One row per epoch, the ``spp.csv`` columns (`gnss_obs.SppResult.to_frame`):
        ``gps_time_s`` (s since the GPS epoch), ``lat_deg, lon_deg, h_m``, ENU velocity
        (m/s), a clock bias per system (m), DOPs, σ (m, m/s), protection levels (m), RAIM
        flags.
    result : gnss_obs.SppResult
        The solution with its per-satellite details (``result.satellites``).
    config : gnss_obs.SppConfig
        The settings solved with.
    errors : pandas.DataFrame or None
        `railnav.evaluation.spp_accuracy.spp_errors` against the reference (ENU errors in m,
        speed error in m/s), None without one.
    reference : pandas.DataFrame or None
        The reference trajectory read (``gps_time_s, lat_deg, lon_deg, h_m``).
    base, smooth_window_s, sp3
        The augmentation asked for (base file, smoothing window in s, SP3 files).
    """

    frame: pd.DataFrame
    result: SppResult
    config: SppConfig
    errors: pd.DataFrame | None = None
    reference: pd.DataFrame | None = None
    base: str | os.PathLike | None = None
    smooth_window_s: float | None = None
    sp3: tuple = ()

    def accuracy(self) -> SppAccuracy | None:
        """RMS / 95 % figures against the reference (`accuracy_summary`), None without one."""
        return accuracy_summary(self.errors) if self.errors is not None else None

    def lines(self) -> list[str]:
        """The summary ``railnav spp`` prints: mode, systems, epochs, satellites, DOP,
        RAIM, and the accuracy with a reference."""
        frame, mc = self.frame, self.config.measurement
        fixed = frame[frame["fix_ok"]]
        mode = ("DGNSS (base " + Path(self.base).name + ")" if self.base else "single point")
        mode += (f", code smoothed over {self.smooth_window_s:g} s"
                 if self.smooth_window_s else "")
        mode += ", precise orbits (SP3)" if self.sp3 else ", broadcast orbits"
        out = [f"mode                 {mode}",
               f"systems              {mc.systems} (ionosphere: {mc.ionosphere})",
               f"epochs               {len(frame)} ({len(fixed)} with a fix, "
               f"{int(frame['velocity_ok'].sum())} with a velocity)",
               f"satellites used      {fixed['n_sat_used'].mean():.1f} mean, "
               f"{int(fixed['n_sat_used'].min()) if len(fixed) else 0} min",
               f"HDOP / VDOP median   {np.nanmedian(fixed['hdop']):.2f} / "
               f"{np.nanmedian(fixed['vdop']):.2f}",
               f"RAIM                 {int((~fixed['raim_ok']).sum())} epochs failed, "
               f"{int(frame['n_excluded'].sum())} satellites excluded"]
        accuracy = self.accuracy()
        return out + (accuracy.lines() if accuracy is not None else [])

    def write(self, out_dir: str | os.PathLike, *, plot: bool = True) -> list[Path]:
        """Write ``spp.csv`` (`FLOAT_FORMAT`, ``gps_time_s`` to the µs) and, with `plot`,
        ``spp.png`` (`plot_spp`) into `out_dir` (created), each atomically; returns the
        paths written."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        frame = self.frame
        atomic_write_csv(out / "spp.csv", frame.assign(
            gps_time_s=frame["gps_time_s"].map(TIME_FORMAT.format)), float_format=FLOAT_FORMAT)
        written = [out / "spp.csv"]
        if plot:
            plot_spp(frame, out / "spp.png", errors=self.errors, reference=self.reference)
            written.append(out / "spp.png")
        return written


def spp_config(*, systems: str = DEFAULT_SYSTEMS, ionosphere: str = DEFAULT_IONOSPHERE,
               elevation_mask_deg: float = DEFAULT_ELEVATION_MASK_DEG,
               raim: bool = True) -> SppConfig:
    """The `gnss_obs.SppConfig` of `spp_files` (its other fields the library's defaults);
    `systems` is read case- and blank-insensitively (``" ge"`` is ``"GE"``).

    Raises
    ------
    gnss_obs.GnssError
        Systems that are not distinct letters of ``GERCJ``, an unknown ionosphere, a mask
        outside [-90, 90) deg.
    """
    return SppConfig(measurement=MeasurementConfig(systems=systems.strip().upper(),
                                                   ionosphere=ionosphere),
                     elevation_mask_deg=elevation_mask_deg, raim=raim)


def spp_files(obs: str | os.PathLike, nav: str | os.PathLike, *,
              systems: str = DEFAULT_SYSTEMS, ionosphere: str = DEFAULT_IONOSPHERE,
              elevation_mask_deg: float = DEFAULT_ELEVATION_MASK_DEG, raim: bool = True,
              base: str | os.PathLike | None = None,
              base_position: tuple[float, float, float] | None = None,
              max_age_s: float | None = None, smooth_window_s: float | None = None,
              sp3: str | os.PathLike | Sequence[str | os.PathLike] = (),
              reference: str | os.PathLike | None = None,
              progress: Callable[[int, int], None] | None = None) -> SppRun:
    """Single-point (or code-differential) positions, velocities and clocks of every epoch
    of a RINEX observation file: ``railnav spp`` with the same defaults.

    Parameters
    ----------
    obs, nav : path
        Rover RINEX observations (epochs in GPS time) and broadcast navigation.
    systems : str
        GNSS systems to use, letters of ``GERCJ``; default railnav's `DEFAULT_SYSTEMS`
        (``"G"``, every command's; the module docstring says why it is not
        ``gnss_obs.SppConfig``'s ``"GE"``).
    ionosphere : {"klobuchar", "iono-free", "none"}
        Ionosphere handling (`gnss_obs.MeasurementConfig`).
    elevation_mask_deg : float
        Satellites below this elevation are not used, deg.
    raim : bool
        Exclude faulty satellites (FDE); False only flags the epochs.
    base : path, optional
        Base-station RINEX observations: code-differential (DGNSS) corrections per
        satellite and epoch (`gnss_obs.augment`).
    base_position : (lat_deg, lon_deg, h_m), optional
        Base antenna latitude and longitude (deg) and ellipsoidal height (m); default the
        base header's ``APPROX POSITION XYZ``. Needs `base`.
    max_age_s : float, optional
        Oldest base correction applied, s (default `gnss_obs.DgpsConfig`'s, 30 s).
    smooth_window_s : float, optional
        Carrier-smooth the code (rover and base) over up to this many seconds
        (`gnss_obs.SmoothingConfig`); None: raw code.
    sp3 : path or sequence of path
        Precise orbit/clock files instead of the broadcast ephemeris.
    reference : path, optional
        Reference trajectory (`read_reference_trajectory`: the project's columns or GPS
        week / seconds of week): errors in `SppRun.errors`.
    progress : callable(done, total), optional
        Called after each epoch solved.

    Raises
    ------
    gnss_obs.GnssError
        A bad setting (`spp_config`), a file that cannot be read, no usable epoch, a base
        position without a base file.
    railnav.errors.ConfigError
        A reference file that cannot be read.
    """
    config = spp_config(systems=systems, ionosphere=ionosphere,
                        elevation_mask_deg=elevation_mask_deg, raim=raim)
    sp3 = (sp3,) if isinstance(sp3, (str, os.PathLike)) else tuple(sp3)
    rover = read_rinex_obs(obs)
    broadcast = read_rinex_nav(nav)
    ref = read_reference_trajectory(reference) if reference is not None else None
    aug = augment_files(rover, broadcast, config.measurement, base_path=base,
                        base_lat_lon_h=base_position, max_age_s=max_age_s,
                        smoothing=(SmoothingConfig(window_s=smooth_window_s)
                                   if smooth_window_s is not None else None),
                        sp3_paths=sp3)
    result = solve_spp(aug.obs, broadcast, config, corrections=aug.corrections,
                       max_correction_age_s=aug.max_age_s, precise=aug.precise,
                       progress=progress)
    frame = result.to_frame()
    errors = spp_errors(frame, ref) if ref is not None else None
    return SppRun(frame, result, config, errors, ref, base=base,
                  smooth_window_s=smooth_window_s, sp3=sp3)
