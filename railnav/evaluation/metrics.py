"""Errors of a navigation run against the truth, and their summaries.

`error_series` compares the stored estimates with the true trajectory at the same times.
The position error ``r_est − r_true`` is resolved in the track's frame at the TRUE point
(`trackmodel.project` conventions): **along** the tangent, **cross**-track horizontally to
the right of +s, **vertical** along the up-normal. For the track-constrained filters the
estimate is on the track, so the cross-track error is zero up to the chord of a curve
(``κ δs²/2``) — reported, not assumed. NEES uses the filter's own covariance on the
state components whose truth is known (`filter.truth_states`).

`summarize` gives RMS and maximum of each error over the run, over a window, and within
each GNSS outage (its maximum and its value at the outage's end).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, fields

import numpy as np
import numpy.typing as npt
import pandas as pd

from ekf.packing import unpack_sym
from railnav.errors import ConfigError
from railnav.filters.track_frame import track_axes_many_n
from trackmodel.earth import C_n_e, geodetic_to_ecef

__all__ = ["ErrorSeries", "error_series", "summarize", "ERROR_QUANTITIES", "check_trip_times"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

#: Summarized error columns and their units.
ERROR_QUANTITIES = {"along_track_m": "m", "cross_track_m": "m", "vertical_m": "m",
                    "position_3d_m": "m", "speed_mps": "m/s", "yaw_rad": "rad",
                    "pitch_rad": "rad", "roll_rad": "rad", "attitude_rad": "rad",
                    "latitude_rad": "rad", "v_north_mps": "m/s"}


@dataclass(frozen=True)
class ErrorSeries:
    """Errors (estimate − truth) at the stored times (arrays (K,); NaN when unknown).

    Attributes
    ----------
    time_s : ndarray
    along_track_m, cross_track_m, vertical_m, position_3d_m : ndarray
        Position error in the track frame at the true point, and its norm, m.
    speed_mps : ndarray
        Signed speed error, m/s.
    yaw_rad, pitch_rad, roll_rad : ndarray
        Attitude errors (yaw wrapped to [−π, π)), rad.
    attitude_rad : ndarray
        Largest of the three attitude errors in magnitude, rad.
    latitude_rad : ndarray
        The paper's latitude error, rad.
    v_north_mps : ndarray
        The paper's ``V_Y`` (north velocity) error, m/s.
    nees : ndarray
        Normalized estimation error squared on the known states.
    nees_dof : int
        Number of those states.
    """

    time_s: Array
    along_track_m: Array
    cross_track_m: Array
    vertical_m: Array
    position_3d_m: Array
    speed_mps: Array
    yaw_rad: Array
    pitch_rad: Array
    roll_rad: Array
    attitude_rad: Array
    latitude_rad: Array
    v_north_mps: Array
    nees: Array
    nees_dof: int

    @property
    def compared(self) -> int:
        """How many estimates have a reference sample (a finite along-track error). With
        none (a reference whose every sample is off the track or outside the run), the
        runs write no ``errors.csv``: only empty rows."""
        return int(np.isfinite(self.along_track_m).sum())

    def to_frame(self) -> pd.DataFrame:
        """The ``errors.csv`` table: one column per field (units in the names)."""
        return pd.DataFrame({f.name: getattr(self, f.name) for f in fields(self)
                             if f.name != "nees_dof"})


def _truth_at(truth, t: Array) -> dict[str, Array]:
    """True trajectory values at times ``t`` (linear interpolation; yaw unwrapped)."""
    out = {}
    for name in ("s", "v", "lat", "lon", "h", "pitch", "roll"):
        out[name] = np.interp(t, truth.time_s, getattr(truth, name))
    out["yaw"] = np.interp(t, truth.time_s, np.unwrap(truth.yaw))
    out["v_n"] = np.column_stack([np.interp(t, truth.time_s, truth.v_n[:, i]) for i in range(3)])
    return out


def _largest(att: dict[str, Array]) -> Array:
    """Largest |attitude error| per sample (NaN where all three are unknown)."""
    a = np.abs(np.column_stack([att["yaw"], att["pitch"], att["roll"]]))
    known = np.isfinite(a)
    return np.where(known.any(axis=1), np.where(known, a, -np.inf).max(axis=1), np.nan)


def _wrap(angle: Array) -> Array:
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


def error_series(result, truth, track, *, clock_truth=None, known_states=None,
                 valid=None) -> ErrorSeries:
    """Errors of a `railnav.NavigationResult` against a `railnav.simulation.truth.Truth`.

    Parameters
    ----------
    result : NavigationResult
    truth : railnav.simulation.truth.Truth
        Unknown quantities NaN (a reference: `railnav.evaluation.reference`).
    track : trackmodel.Track
        The track of the truth (for the along/cross/vertical frame).
    clock_truth : callable, optional
        ``clock_truth(time_s) -> (bias_m, drift_mps)``; without it the clock states are
        left out of the NEES.
    known_states : tuple of str, optional
        Only these states (of those ``truth_states`` knows) count in the NEES.
    valid : ndarray of bool, shape (K,), optional
        Estimates with a truth (default all); the others get NaN errors.

    Returns
    -------
    ErrorSeries
    """
    est = result.estimates
    t = est["time_s"].to_numpy()
    if truth.time_s.size == 0:
        nan = np.full(t.size, np.nan)
        return ErrorSeries(t, *([nan] * 12), 0)
    tr = _truth_at(truth, t)
    earth = track.earth
    r_est = geodetic_to_ecef(np.radians(est["lat_deg"].to_numpy()),
                             np.radians(est["lon_deg"].to_numpy()), est["h_m"].to_numpy(),
                             earth=earth)
    r_true = geodetic_to_ecef(tr["lat"], tr["lon"], tr["h"], earth=earth)
    e_n = np.einsum("kji,kj->ki", C_n_e(tr["lat"], tr["lon"]), r_est - r_true)
    point = track.at(np.clip(tr["s"], 0.0, track.length_m))
    axes = track_axes_many_n(point.azimuth, point.elevation)
    right, up = axes["cross"], axes["up"]
    nan = np.full(t.size, np.nan)
    att = {}
    for name in ("yaw", "pitch", "roll"):
        col = f"{name}_deg"
        att[name] = _wrap(np.radians(est[col].to_numpy()) - tr[name]) if col in est else nan
    nees, dof = _nees(result, truth, t, clock_truth, known_states)
    lat_est = np.radians(est["lat_deg"].to_numpy())
    errors = ErrorSeries(
        time_s=t, along_track_m=np.einsum("ki,ki->k", e_n, point.u_n),
        cross_track_m=np.einsum("ki,ki->k", e_n, right),
        vertical_m=np.einsum("ki,ki->k", e_n, up), position_3d_m=np.linalg.norm(e_n, axis=1),
        speed_mps=est["speed_mps"].to_numpy() - tr["v"], yaw_rad=att["yaw"],
        pitch_rad=att["pitch"], roll_rad=att["roll"],
        attitude_rad=_largest(att) if "yaw_deg" in est else nan,
        latitude_rad=lat_est - tr["lat"],
        v_north_mps=est["v_north_mps"].to_numpy() - tr["v_n"][:, 1], nees=nees, nees_dof=dof)
    if valid is None:
        return errors
    return ErrorSeries(**{f.name: np.where(valid, getattr(errors, f.name), np.nan)
                          if f.name not in ("time_s", "nees_dof") else getattr(errors, f.name)
                          for f in fields(errors)})


def _nees(result, truth, t: Array, clock_truth, known_states=None) -> tuple[Array, int]:
    """NEES on the known state components (NaN without a `truth_states` method)."""
    filt = result.filter_object
    if not hasattr(filt, "truth_states"):
        return np.full(t.size, np.nan), 0
    sub = _TruthView(truth, t)
    bias, drift = clock_truth(t) if clock_truth is not None else (None, None)
    x_true, known = filt.truth_states(sub, np.zeros(t.size) if bias is None else bias,
                                      np.zeros(t.size) if drift is None else drift)
    if clock_truth is None:
        known &= ~np.isin(np.array(result.layout.names), ("clock_bias", "clock_drift"))
    if known_states is not None:
        known &= np.isin(np.array(result.layout.names), tuple(known_states))
    idx = np.flatnonzero(known)
    err = result.x[:, idx] - x_true[:, idx]
    for k, name in enumerate(np.array(result.layout.names)[idx]):
        if name == "yaw":
            err[:, k] = _wrap(err[:, k])
    P = unpack_sym(result.P)[:, idx][:, :, idx]
    nees = np.einsum("ki,ki->k", err, np.linalg.solve(P, err[..., None])[..., 0])
    return nees, int(idx.size)


class _TruthView:
    """The truth interpolated at given times, with the attribute names of `Truth`."""

    def __init__(self, truth, t: Array) -> None:
        values = _truth_at(truth, t)
        for name in ("s", "v", "pitch", "roll", "lat", "lon", "h"):
            setattr(self, name, values[name])
        self.yaw = values["yaw"]
        self.v_n = values["v_n"]
        self.mount_rad = getattr(truth, "mount_rad", None)
        self.time_s = t
        r_e = geodetic_to_ecef(values["lat"], values["lon"], values["h"])
        self.r_e = r_e


def _stats(x: Array) -> dict[str, float | None]:
    x = x[np.isfinite(x)]
    if x.size == 0:
        return {"rms": None, "max": None}
    return {"rms": float(np.sqrt(np.mean(x * x))), "max": float(np.max(np.abs(x)))}


def check_trip_times(end_s: float, *, outages=(), window: tuple[float, float] | None = None,
                     early_end: str = "") -> None:
    """Outages and the summary window must fall inside the trip ``[0, end_s]``.

    An outage or window that starts at or after the trip's end would change nothing and
    report nothing (issue 18: it was silently ignored): an error. One that starts inside
    and ends after the end is cut there by the run: a warning says so. When the outages are
    a scenario's and its data end before them (`early_end` says where: the trip reached the
    track's end before the scenario's duration, or the simulated files end there, as fixes
    do before an outage that lasts to the end), an outage after the end is the scenario's,
    not a mistake: a warning.

    Parameters
    ----------
    end_s : float
        The trip's last time, s from its start.
    outages : sequence of (start_s, duration_s)
    window : (start_s, end_s), optional
    early_end : str
        Where the data of a scenario's outages end early (e.g. ``"at the track's end"``);
        empty: the outages are the caller's own.

    Raises
    ------
    ConfigError
        Naming the outage or window and the trip's end.
    """
    spans = [("outage", float(a), float(a) + float(d)) for a, d in outages]
    if window is not None:
        spans.append(("window", float(window[0]), float(window[1])))
    for name, start, stop in spans:
        label = f"{name} {start:g}-{stop:g} s"
        if start >= end_s and name == "outage" and early_end:
            log.warning("%s starts after the trip ends (%g s, %s): no effect", label,
                        end_s, early_end)
        elif start >= end_s:
            raise ConfigError(f"{label} starts after the trip ends at {end_s:g} s")
        elif stop > end_s:
            log.warning("%s ends after the trip (at %g s): only %g-%g s is covered", label,
                        end_s, start, end_s)


def summarize(errors: ErrorSeries, *, window: tuple[float, float] | None = None,
              outages=()) -> dict:
    """RMS and maximum |error| per quantity; also over `window` and for each outage.

    Parameters
    ----------
    errors : ErrorSeries
    window : (start_s, end_s), optional
        A user window (e.g. the 2017 paper's [900, 1000] s).
    outages : sequence of (start_s, duration_s)

    Returns
    -------
    dict
        ``{"all": {quantity: {"rms", "max"}}, "window": {...} (if given),
        "outages": [{"start_s", "duration_s", "at_end": {quantity: value},
        "max": {quantity: value}}], "nees": {"mean", "dof"}}``.
    """
    def block(mask: npt.NDArray[np.bool_]) -> dict:
        return {q: _stats(getattr(errors, q)[mask]) for q in ERROR_QUANTITIES}

    t = errors.time_s
    out: dict = {"all": block(np.ones(t.size, dtype=bool))}
    if window is not None:
        inside = (t >= window[0]) & (t <= window[1])
        out["window"] = {"start_s": float(window[0]), "end_s": float(window[1]),
                         **block(inside)}
    outage_rows = []
    for start, duration in outages:
        inside = np.flatnonzero((t >= start) & (t < start + duration))
        if inside.size == 0:
            continue
        last = inside[-1]
        outage_rows.append({
            "start_s": float(start), "duration_s": float(duration),
            "end_sample_s": float(t[last]),
            "at_end": {q: _finite(getattr(errors, q)[last]) for q in ERROR_QUANTITIES},
            "max": {q: _stats(getattr(errors, q)[inside])["max"] for q in ERROR_QUANTITIES}})
    out["outages"] = outage_rows
    finite = errors.nees[np.isfinite(errors.nees)]
    out["nees"] = {"mean": float(finite.mean()) if finite.size else None,
                   "dof": errors.nees_dof}
    return out


def _finite(value: float) -> float | None:
    return float(value) if np.isfinite(value) else None
