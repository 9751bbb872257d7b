"""Scripted events of a trip's GNSS: satellite faults and (partial) outages.

`Outage` is the one outage type of the project: the simulator drops the satellites it
hides, and a filter skips the GNSS data of a total outage (`in_outages`). Times are seconds
from a stated origin: the trip start (as ``railnav run/simulate --outage START:DURATION``
give them); the simulator is told that origin (`gnss_obs.simulate.GnssSimConfig.
time_origin_gps_time_s`), whatever GPS time its first epoch has.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from gnss_obs.errors import GnssError

__all__ = ["SatelliteFault", "Outage", "apply_faults", "visible_after_outages", "in_outages"]

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


@dataclass(frozen=True, eq=False)
class Outage:
    """A window with fewer satellites.

    Parameters
    ----------
    start_s, duration_s : float
        Window, s from the time origin (the trip start).
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

    @property
    def total(self) -> bool:
        """No satellite is kept inside the window (a filter sees no GNSS data there)."""
        return self.max_satellites == 0 and self.elevation_mask_deg is None

    def __iter__(self):
        """An outage unpacks as its window ``(start_s, duration_s)`` (JSON, tables)."""
        return iter((self.start_s, self.duration_s))

    def _key(self) -> tuple:
        if self.total:
            return (self.start_s, self.duration_s)
        return (self.start_s, self.duration_s, self.max_satellites, self.elevation_mask_deg)

    def __eq__(self, other) -> bool:
        """Outages are equal by their fields; a total outage also equals its
        ``(start_s, duration_s)`` pair (the form configs and JSON carry)."""
        if isinstance(other, Outage):
            return self._key() == other._key()
        if isinstance(other, (tuple, list)) and len(other) == 2:
            return self.total and self._key() == tuple(other)
        return NotImplemented

    def __hash__(self) -> int:
        return hash(self._key())

    def active(self, t_rel: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """True where `t_rel` (s from the time origin) is inside the window."""
        t_rel = np.asarray(t_rel, dtype=float)
        return (t_rel >= self.start_s) & (t_rel < self.start_s + self.duration_s)

    @classmethod
    def of(cls, value) -> "Outage":
        """An `Outage` from an outage or a ``(start_s, duration_s)`` pair (a total one)."""
        if isinstance(value, cls):
            return value
        try:
            start_s, duration_s = (float(x) for x in value)
        except (TypeError, ValueError):
            raise GnssError(f"outage: need (start_s, duration_s), got {value!r}") from None
        return cls(start_s, duration_s)


def in_outages(t: npt.ArrayLike, outages) -> npt.NDArray[np.bool_]:
    """True where times `t` (s from the time origin) fall inside a *total* outage: where a
    filter has no GNSS data (partial outages leave it some).

    Parameters
    ----------
    t : array_like
        Times, s.
    outages : sequence of Outage or (start_s, duration_s)

    Returns
    -------
    ndarray of bool, shape of `t`
    """
    t = np.asarray(t, dtype=float)
    inside = np.zeros(t.shape, dtype=bool)
    for outage in map(Outage.of, outages):
        if outage.total:
            inside |= outage.active(t)
    return inside


def apply_faults(t: Array, epoch: np.ndarray, sv: np.ndarray,
                 faults: tuple[SatelliteFault, ...], *, origin_s: float
                 ) -> tuple[Array, Array]:
    """Pseudorange (m) and range-rate (m/s) errors of the faults, per observation row
    (`t` and `origin_s` in one time scale, e.g. GPS s)."""
    pr, rr = np.zeros(sv.size), np.zeros(sv.size)
    t_rel = t[epoch] - origin_s
    for f in faults:
        on = (sv == f.sv) & (t_rel >= f.start_s) & (t_rel < f.start_s + f.duration_s)
        pr[on] += f.step_m + f.ramp_mps * (t_rel[on] - f.start_s)
        if f.affects_doppler:
            rr[on] += f.ramp_mps
    return pr, rr


def visible_after_outages(t: Array, epoch: np.ndarray, elevation: Array,
                          outages: tuple[Outage, ...], *, mask_rad: float, origin_s: float
                          ) -> npt.NDArray[np.bool_]:
    """Observation rows that survive the elevation mask and the outages (`t` and
    `origin_s` in one time scale)."""
    keep = elevation >= mask_rad
    t_rel = t[epoch] - origin_s
    for o in outages:
        inside = o.active(t_rel)
        if o.elevation_mask_deg is not None:
            keep &= ~inside | (elevation >= np.deg2rad(o.elevation_mask_deg))
        for k in np.unique(epoch[inside & keep]):
            rows = np.flatnonzero((epoch == k) & keep)
            ranked = rows[np.argsort(-elevation[rows])]
            keep[ranked[o.max_satellites:]] = False
    return keep
