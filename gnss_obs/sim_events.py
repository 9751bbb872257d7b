"""Scripted events of the GNSS simulator: satellite faults and (partial) outages.

Times are seconds from the first epoch of the simulation (as ``railnav simulate
--outage START:DURATION`` gives them).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from gnss_obs.errors import GnssError

__all__ = ["SatelliteFault", "Outage", "apply_faults", "visible_after_outages"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class SatelliteFault:
    """A fault on one satellite's measurements from `start_s` for `duration_s`.

    The pseudorange error is ``step_m + ramp_mps · (t - start)``; with
    ``affects_doppler`` the range rate also carries ``ramp_mps`` (a consistent signal
    fault), otherwise only the pseudorange is corrupted (a code fault).

    Parameters
    ----------
    sv : str
        Satellite, e.g. ``"G05"``.
    start_s : float
        Start, s from the first epoch.
    duration_s : float
        Length, s (inf = to the end).
    step_m : float
        Constant pseudorange error, m.
    ramp_mps : float
        Pseudorange error growth rate, m/s.
    affects_doppler : bool
        Add `ramp_mps` to the range rate.
    """

    sv: str
    start_s: float
    duration_s: float = math.inf
    step_m: float = 0.0
    ramp_mps: float = 0.0
    affects_doppler: bool = False

    def __post_init__(self) -> None:
        if not (math.isfinite(self.start_s) and self.start_s >= 0 and self.duration_s > 0):
            raise GnssError(f"fault {self.sv}: need start_s >= 0 and duration_s > 0")
        if not (math.isfinite(self.step_m) and math.isfinite(self.ramp_mps)):
            raise GnssError(f"fault {self.sv}: step_m and ramp_mps must be finite")


@dataclass(frozen=True)
class Outage:
    """A window with fewer satellites.

    Parameters
    ----------
    start_s, duration_s : float
        Window, s from the first epoch.
    max_satellites : int
        Satellites kept (the highest ones); 0 = total outage.
    elevation_mask_deg : float, optional
        A raised elevation mask inside the window, deg (applied before `max_satellites`;
        set `max_satellites` large to use the mask alone).
    """

    start_s: float
    duration_s: float
    max_satellites: int = 0
    elevation_mask_deg: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.start_s) and self.start_s >= 0 and self.duration_s > 0):
            raise GnssError("outage: need start_s >= 0 and duration_s > 0")
        if self.max_satellites < 0:
            raise GnssError("outage: max_satellites must be >= 0")

    def active(self, t_rel: Array) -> npt.NDArray[np.bool_]:
        """True where `t_rel` (s from the first epoch) is inside the window."""
        return (t_rel >= self.start_s) & (t_rel < self.start_s + self.duration_s)


def apply_faults(t: Array, epoch: np.ndarray, sv: np.ndarray,
                 faults: tuple[SatelliteFault, ...]) -> tuple[Array, Array]:
    """Pseudorange (m) and range-rate (m/s) errors of the faults, per observation row."""
    pr, rr = np.zeros(sv.size), np.zeros(sv.size)
    t_rel = t[epoch] - t[0]
    for f in faults:
        on = (sv == f.sv) & (t_rel >= f.start_s) & (t_rel < f.start_s + f.duration_s)
        pr[on] += f.step_m + f.ramp_mps * (t_rel[on] - f.start_s)
        if f.affects_doppler:
            rr[on] += f.ramp_mps
    return pr, rr


def visible_after_outages(t: Array, epoch: np.ndarray, elevation: Array,
                          outages: tuple[Outage, ...], *, mask_rad: float
                          ) -> npt.NDArray[np.bool_]:
    """Observation rows that survive the elevation mask and the outages."""
    keep = elevation >= mask_rad
    t_rel = t[epoch] - t[0]
    for o in outages:
        inside = o.active(t_rel)
        if o.elevation_mask_deg is not None:
            keep &= ~inside | (elevation >= np.deg2rad(o.elevation_mask_deg))
        for k in np.unique(epoch[inside & keep]):
            rows = np.flatnonzero((epoch == k) & keep)
            ranked = rows[np.argsort(-elevation[rows])]
            keep[ranked[o.max_satellites:]] = False
    return keep
