"""Scoring a run against a reference: railnav's truth.csv, a reference trajectory, or the
better fixes of a fix file.

`read_reference` tells the file by its content:

* ``truth.csv`` written by ``railnav simulate`` (``time_s, s_m, lat_deg, ..., roll_deg``):
  the full truth (s, v, attitude; the velocity in ENU is ``v u_n(s)`` on the track);
* a reference trajectory (``gps_time_s, lat_deg, lon_deg, h_m`` without a ``quality``
  column, or GPS week / seconds of week after a ``#`` header:
  `railnav.evaluation.spp_accuracy.read_reference_trajectory`);
* any fix file `gnss_obs.fixes.read_fixes` reads: the rows of one fix class
  (``quality``, default the best class present) that agree with the track and with their
  neighbours (`screen_fix_reference`).

A trajectory or fix reference is projected on the track (``s``); its speed is the central
difference of ``s`` where both neighbours are within `MAX_REFERENCE_GAP_S`; its attitude
is unknown (NaN). `reference_errors` then gives the `ErrorSeries` of a run
(`railnav.evaluation.metrics.error_series`), NaN where the reference has no sample within
`MAX_REFERENCE_GAP_S` on both sides, NEES on the states the reference knows.
"""
from __future__ import annotations

import logging
import math
import os
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import pandas as pd

from railnav.errors import ConfigError
from railnav.evaluation.metrics import ErrorSeries, error_series
from railnav.simulation.truth import TRUTH_COLUMNS, Truth
from trackmodel.earth import geodetic_to_ecef

__all__ = ["Reference", "read_reference", "reference_kind", "reference_errors",
           "screen_fix_reference", "truth_from_frame", "MAX_REFERENCE_GAP_S",
           "REFERENCE_MAX_OFFSET_M", "REFERENCE_MAX_JUMP_M", "QUALITY_ORDER"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

#: Errors are given where the reference has samples this close on both sides, s; also
#: the largest step of a central-difference speed (`spp_accuracy.MAX_DIFF_GAP_S`).
MAX_REFERENCE_GAP_S = 1.5
#: A reference fix lies at most this far from the track, m: above the largest offset of
#: the Belgian logs' carrier-fixed rows that lie on their track (3.3 m: centre-line,
#: antenna place and fix error), below the 4-6 m between parallel tracks.
REFERENCE_MAX_OFFSET_M = 3.5
#: A reference fix lies at most this far along the track from the straight line between
#: its two neighbours (within `MAX_REFERENCE_GAP_S`), m: a train's acceleration (< 1.5
#: m/s²) bends that line by a·Δt²/8 < 0.5 m over 1.5 s. Rows beyond it are removed worst
#: first, the line recomputed each time.
REFERENCE_MAX_JUMP_M = 1.0
#: Fix classes, best first, for the default reference class.
QUALITY_ORDER = ("rtk_fixed", "rtk_float", "dgps", "single", "dead_reckoning")


@dataclass(frozen=True, eq=False)
class Reference:
    """A reference to score runs against.

    Attributes
    ----------
    truth : railnav.simulation.truth.Truth
        At the reference times (``time_s`` from the trip start); NaN where unknown.
    known_states : tuple of str
        Filter states the reference knows (for NEES).
    report : dict
        Where it came from and what was kept (``summary.json`` ``reference``).
    """

    truth: Truth
    known_states: tuple[str, ...]
    report: dict = field(default_factory=dict)


def truth_from_frame(frame: pd.DataFrame, track, *, path=None) -> Truth:
    """A `Truth` from a ``truth.csv`` table (`TRUTH_COLUMNS`; the ENU velocity is
    ``v u_n(s)`` on `track`, the acceleration the gradient of ``v``)."""
    missing = [c for c in TRUTH_COLUMNS if c not in frame.columns]
    if missing:
        raise ConfigError(f"truth file lacks {', '.join(missing)}", path=path)
    col = {c: frame[c].to_numpy(dtype=float) for c in TRUTH_COLUMNS}
    lat, lon = np.radians(col["lat_deg"]), np.radians(col["lon_deg"])
    u_n = track.at(np.clip(col["s_m"], 0.0, track.length_m)).u_n
    return Truth(time_s=col["time_s"], s=col["s_m"], v=col["speed_mps"],
                 a=np.gradient(col["speed_mps"], col["time_s"]), lat=lat, lon=lon,
                 h=col["h_m"], r_e=geodetic_to_ecef(lat, lon, col["h_m"], earth=track.earth),
                 v_n=col["speed_mps"][:, None] * u_n, yaw=np.radians(col["yaw_deg"]),
                 pitch=np.radians(col["pitch_deg"]), roll=np.radians(col["roll_deg"]))


def _point_truth(time_s: Array, lat: Array, lon: Array, h: Array, track) -> Truth:
    """A `Truth` of points off the track: ``s`` by projection, speed by central
    differences, attitude unknown; a point without height takes the track's."""
    proj = track.project(lat, lon)
    s = proj.s
    points = proj.point
    h = np.where(np.isfinite(h), h, points.h)
    v = np.full(s.size, np.nan)
    if s.size >= 3:
        back, ahead = np.diff(time_s)[:-1], np.diff(time_s)[1:]
        ok = (back <= MAX_REFERENCE_GAP_S) & (ahead <= MAX_REFERENCE_GAP_S)
        v[1:-1] = np.where(ok, (s[2:] - s[:-2]) / (time_s[2:] - time_s[:-2]), np.nan)
    nan = np.full(s.size, np.nan)
    return Truth(time_s=time_s, s=s, v=v, a=nan, lat=lat, lon=lon, h=h,
                 r_e=geodetic_to_ecef(lat, lon, h, earth=track.earth),
                 v_n=v[:, None] * points.u_n, yaw=nan, pitch=nan, roll=nan)


def screen_fix_reference(table: pd.DataFrame, track, *, quality: str | None = None,
                         max_offset_m: float = REFERENCE_MAX_OFFSET_M,
                         max_jump_m: float = REFERENCE_MAX_JUMP_M) -> tuple[Array, dict]:
    """Which fixes can serve as a reference: the class's rows near the track and in line
    with their neighbours.

    Parameters
    ----------
    table : pandas.DataFrame
        A fix table (`gnss_obs.fixes.table.FIX_COLUMNS`).
    track : trackmodel.Track
    quality : str, optional
        The reference class; default the best class of `QUALITY_ORDER` present.
        (`read_reference` raises ConfigError for a class given with a truth or
        trajectory file, or not in `QUALITY_ORDER`.)
    max_offset_m, max_jump_m : float
        `REFERENCE_MAX_OFFSET_M`, `REFERENCE_MAX_JUMP_M`.

    Returns
    -------
    keep : ndarray of bool, shape (N,)
    report : dict
        ``quality, candidates, off_track, jumps, kept`` and the median offset of the kept.
    """
    quality = quality or next(q for q in QUALITY_ORDER if (table["quality"] == q).any())
    cand = (table["quality"] == quality).to_numpy()
    lat = np.radians(table["lat_deg"].to_numpy(dtype=float))
    lon = np.radians(table["lon_deg"].to_numpy(dtype=float))
    proj = track.project(lat, lon)
    offset = np.hypot(proj.cross_track_m, proj.along_m)
    near = cand & (offset <= max_offset_m)
    t = table["gps_time_s"].to_numpy(dtype=float)
    jump = _jumps(t, proj.s, near, max_jump_m)
    keep = near & ~jump
    report = {"quality": quality, "candidates": int(cand.sum()),
              "off_track": int((cand & ~near).sum()), "jumps": int(jump.sum()),
              "kept": int(keep.sum()), "max_offset_m": max_offset_m,
              "max_jump_m": max_jump_m,
              "median_offset_kept_m": float(np.median(offset[keep])) if keep.any() else None}
    return keep, report


def _jumps(t: Array, s: Array, candidate: npt.NDArray[np.bool_], max_jump_m: float
           ) -> npt.NDArray[np.bool_]:
    """Candidates off the line through their candidate neighbours by more than
    `max_jump_m`, removed worst first (one jump does not condemn its neighbours)."""
    idx = np.flatnonzero(candidate)
    jump = np.zeros(t.size, dtype=bool)
    while idx.size >= 3:
        t0, t1, t2 = t[idx[:-2]], t[idx[1:-1]], t[idx[2:]]
        close = (t1 - t0 <= MAX_REFERENCE_GAP_S) & (t2 - t1 <= MAX_REFERENCE_GAP_S)
        line = s[idx[:-2]] + (s[idx[2:]] - s[idx[:-2]]) * (t1 - t0) / (t2 - t0)
        off = np.where(close, np.abs(s[idx[1:-1]] - line), 0.0)
        worst = int(np.argmax(off))
        if off[worst] <= max_jump_m:
            break
        jump[idx[worst + 1]] = True
        idx = np.delete(idx, worst + 1)
    return jump


def read_reference(path: str | os.PathLike, track, *, start_gps_time_s: float,
                   quality: str | None = None, fixes=None) -> Reference:
    """A reference file (module docstring) on `track`, times from the trip start.

    `fixes`, a `gnss_obs.fixes.table.FixLog` already read from `path` (the run's own fix
    file given as its reference), is used instead of reading the file again (whose
    warnings would print again).

    Raises
    ------
    ConfigError
        A truth file without its columns; gnss_obs.GnssInputError for an unreadable fix
        file.
    """
    kind = reference_kind(path, quality)
    if kind == "truth":
        truth = truth_from_frame(pd.read_csv(path), track, path=path)
        return Reference(truth, ("yaw", "pitch", "roll", "s", "v"),
                         {"source": "truth", "path": os.fspath(path)})
    if kind == "trajectory":
        from railnav.evaluation.spp_accuracy import read_reference_trajectory
        frame = read_reference_trajectory(path)
        truth = _point_truth(frame["gps_time_s"].to_numpy() - start_gps_time_s,
                             np.radians(frame["lat_deg"].to_numpy()),
                             np.radians(frame["lon_deg"].to_numpy()), frame["h_m"].to_numpy(),
                             track)
        return Reference(truth, ("s",), {"source": "trajectory", "path": os.fspath(path),
                                         "samples": int(len(frame))})
    return _fix_reference(path, track, start_gps_time_s, quality, fixes)


def reference_kind(path: str | os.PathLike, quality: str | None = None) -> str:
    """What reference file `path` is, by its content (module docstring): ``"truth"``,
    ``"trajectory"`` or ``"fixes"``.

    Raises
    ------
    ConfigError
        A fix class `quality` for a truth or trajectory file, or an unknown class.
    """
    from gnss_obs.fixes.read import detect_fix_format
    head = _header(path) if detect_fix_format(path) == "csv" else set()
    trajectory = bool(head) and ("quality" not in head and {
        "gps_time_s", "lat_deg", "lon_deg", "h_m"} <= head or any(c.startswith("#") for c in head))
    truth = {"time_s", "s_m", "speed_mps"} <= head
    if quality is not None and (truth or trajectory):
        raise ConfigError("a reference class (quality) applies to a fix file only, not to a "
                          "truth or trajectory file", path=path)
    if quality is not None and quality not in QUALITY_ORDER:
        raise ConfigError(f"unknown fix class {quality!r} (known: {', '.join(QUALITY_ORDER)})")
    return "truth" if truth else "trajectory" if trajectory else "fixes"


def _header(path) -> set[str]:
    """The column names of a CSV's first line (empty for other files)."""
    try:
        with open(path, encoding="utf-8") as fh:
            first = fh.readline()
    except UnicodeDecodeError:
        return set()
    return {c.strip() for c in first.strip().split(",")} if "," in first else set()


def _fix_reference(path, track, start_gps_time_s: float, quality, fixes=None) -> Reference:
    from gnss_obs.fixes.read import read_fixes
    table = (fixes if fixes is not None else read_fixes(path)).table
    keep, report = screen_fix_reference(table, track, quality=quality)
    if not keep.any():
        log.warning("%s: none of the %d %s fixes agrees with the track: no reference",
                    path, report["candidates"], report["quality"])
    ref = table[keep]
    truth = _point_truth(ref["gps_time_s"].to_numpy(dtype=float) - start_gps_time_s,
                         np.radians(ref["lat_deg"].to_numpy(dtype=float)),
                         np.radians(ref["lon_deg"].to_numpy(dtype=float)),
                         ref["h_m"].to_numpy(dtype=float), track)
    return Reference(truth, ("s",), {"source": "fixes", "path": os.fspath(path), **report})


def reference_errors(result, reference: Reference, track, *, clock_truth=None) -> ErrorSeries:
    """Errors of a run against `reference`, NaN where the reference has no sample within
    `MAX_REFERENCE_GAP_S` on both sides of an estimate (module docstring)."""
    truth = reference.truth
    t = result.estimates["time_s"].to_numpy()
    if truth.time_s.size == 0:
        return error_series(result, truth, track, known_states=(), valid=np.zeros(t.size, bool))
    j = np.searchsorted(truth.time_s, t)
    before = np.where(j > 0, t - truth.time_s[np.maximum(j - 1, 0)], math.inf)
    after = np.where(j < truth.time_s.size, truth.time_s[np.minimum(j, truth.time_s.size - 1)]
                     - t, math.inf)
    exact = np.minimum(before, after) <= 1e-6
    valid = exact | ((before <= MAX_REFERENCE_GAP_S) & (after <= MAX_REFERENCE_GAP_S))
    return error_series(result, truth, track, clock_truth=clock_truth,
                        known_states=reference.known_states, valid=valid)
