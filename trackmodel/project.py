"""Projection of points onto a track: nearest ``s`` and the offsets from the track.

For each point the nearest track point is found in three vectorised stages: the nearest
of dense samples of the track (a k-d tree in ECEF; samples every `SAMPLE_STEP_M` metres
and closer in sharp curves), a Newton step on the local quadratic model of the track at
that sample, then Newton steps on the exact track (`Track.at`) until the along-track
residual is below `tol_m`.

Offsets are measured in the track's own frame at the projected point: along the tangent
``u``; **cross-track** along the horizontal unit vector to the *right* of the direction of
increasing ``s``, ``[cosA, −sinA, 0]`` (ENU), positive to the right; **vertical** along
``[−sinϑ sinA, −sinϑ cosA, cosϑ]`` (the up-normal, ⟂ to both), positive above the track.
Beyond the ends the point projects to ``s = 0`` or ``s = length_m`` with a non-zero
along-track offset.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field, fields

import numpy as np
import numpy.typing as npt
import pandas as pd
from scipy.spatial import cKDTree

from trackmodel.earth import C_n_e, geodetic_to_ecef

log = logging.getLogger(__name__)

__all__ = ["Projection", "Projector", "SAMPLE_STEP_M"]

Array = npt.NDArray[np.float64]

#: Spacing of the seed samples on straights and gentle curves, m.
SAMPLE_STEP_M = 20.0
#: In curves the seed spacing is at most this angle of turn times the radius, rad.
SAMPLE_TURN_RAD = 0.1
#: Newton's derivative is kept above this fraction of 1 (points near a curve's centre).
MIN_NEWTON_SLOPE = 0.2
MAX_NEWTON_STEPS = 8


@dataclass(frozen=True)
class Projection:
    """Points projected onto a track; arrays of shape (N,).

    Attributes
    ----------
    s : ndarray
        Along-track distance of the nearest track point, m.
    cross_track_m : ndarray
        Horizontal offset across the track, m, positive to the right of travel (+s).
    vertical_m : ndarray
        Offset along the track's up-normal, m, positive above the track.
    along_m : ndarray
        Residual along the tangent, m (zero except beyond the track ends).
    distance_m : ndarray
        Distance from the point to the track point, m.
    point : trackmodel.TrackPoint, optional
        The track at ``s`` (`Track.at`, computed for the offsets: a caller needing the
        track there reads it instead of asking again).
    """

    s: Array
    cross_track_m: Array
    vertical_m: Array
    along_m: Array
    distance_m: Array
    point: object = field(default=None, repr=False, compare=False)

    def to_frame(self) -> pd.DataFrame:
        """The fields as columns ``s_m, cross_track_m, vertical_m, along_m, distance_m``."""
        cols = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "point"}
        cols["s_m"] = cols.pop("s")
        return pd.DataFrame(cols)[["s_m", "cross_track_m", "vertical_m", "along_m",
                                   "distance_m"]]


def _e(lat: Array, lon: Array, *v_n: Array) -> tuple[Array, ...]:
    """ENU vectors, each (N, 3), at (lat, lon) to ECEF (the rotation computed once for
    all: a projection's Newton step turns its tangent and its derivative)."""
    C = C_n_e(lat, lon)
    return tuple(np.einsum("...ij,...j->...i", C, v) for v in v_n)


class Projector:
    """Nearest-point search on one track (the samples and k-d tree are built once).

    Parameters
    ----------
    track : trackmodel.track.Track
    """

    def __init__(self, track) -> None:
        self.track = track
        tab = track.table
        s = []
        for k in range(len(track.sections)):
            kappa = max(abs(tab.curvature0[k]), abs(tab.curvature1[k]))
            step = SAMPLE_STEP_M if kappa == 0 else min(SAMPLE_STEP_M, SAMPLE_TURN_RAD / kappa)
            n = max(1, int(np.ceil(tab.length[k] / step)))
            s.append(tab.s_start[k] + tab.length[k] * np.arange(n) / n)
        s.append([track.length_m])
        self.s = np.concatenate(s)
        pt = track.at(self.s)
        self.r_e = pt.r_e
        self.u_e, self.k_e = _e(pt.lat, pt.lon, pt.u_n, pt.du_ds_n)
        self.tree = cKDTree(self.r_e)

    def _seed(self, p_e: Array) -> Array:
        """Nearest sample, then one Newton step on the local quadratic model."""
        _, j = self.tree.query(p_e)
        d = p_e - self.r_e[j]
        ds = np.einsum("ij,ij->i", self.u_e[j], d)
        slope = np.maximum(1.0 - np.einsum("ij,ij->i", self.k_e[j], d), MIN_NEWTON_SLOPE)
        return np.clip(self.s[j] + ds / slope, 0.0, self.track.length_m)

    def project(self, lat: npt.ArrayLike, lon: npt.ArrayLike, h: npt.ArrayLike | None = None,
                *, tol_m: float = 1e-7, s_guess: npt.ArrayLike | None = None) -> Projection:
        """Project geodetic points onto the track.

        Parameters
        ----------
        lat, lon : array_like, shape (N,)
            Geodetic latitude and longitude, rad.
        h : array_like, shape (N,), optional
            Ellipsoidal height, m. ``None``: horizontal projection (each point takes the
            height of the track where it projects; ``vertical_m`` is then ≈ 0).
        tol_m : float
            Stop when every along-track correction is below this, m.
        s_guess : array_like, shape (N,), optional
            Start the Newton steps here instead of at the nearest sample: the nearest
            point on the guess's pass of the track (a local minimum of the distance; a
            track through the same place twice has one per pass).

        Returns
        -------
        Projection
        """
        lat, lon = (np.atleast_1d(np.asarray(x, dtype=float)).ravel() for x in (lat, lon))
        h_given = None if h is None else np.broadcast_to(
            np.asarray(h, dtype=float), lat.shape).ravel()
        L = self.track.length_m
        if s_guess is None:
            s = self._seed(geodetic_to_ecef(lat, lon, 0.0 if h is None else h_given,
                                            earth=self.track.earth))
        else:
            s = np.clip(np.broadcast_to(np.asarray(s_guess, dtype=float), lat.shape), 0.0, L)
        for _ in range(MAX_NEWTON_STEPS):
            pt = self.track.at(s)
            p_e = geodetic_to_ecef(lat, lon, pt.h if h is None else h_given,
                                   earth=self.track.earth)
            d = p_e - pt.r_e
            u_e, k_e = _e(pt.lat, pt.lon, pt.u_n, pt.du_ds_n)
            slope = np.maximum(1.0 - np.einsum("ij,ij->i", k_e, d), MIN_NEWTON_SLOPE)
            ds = np.einsum("ij,ij->i", u_e, d) / slope
            s_new = np.clip(s + ds, 0.0, L)
            done = np.abs(s_new - s).max(initial=0.0) < tol_m
            s = s_new
            if done:
                break
        return self._offsets(s, lat, lon, h_given)

    def _offsets(self, s: Array, lat: Array, lon: Array, h: Array | None) -> Projection:
        pt = self.track.at(s)
        p_e = geodetic_to_ecef(lat, lon, pt.h if h is None else h, earth=self.track.earth)
        d_n = np.einsum("...ji,...j->...i", C_n_e(pt.lat, pt.lon), p_e - pt.r_e)
        sA, cA = np.sin(pt.azimuth), np.cos(pt.azimuth)
        sE, cE = np.sin(pt.elevation), np.cos(pt.elevation)
        right_n = np.stack([cA, -sA, np.zeros_like(sA)], axis=-1)
        normal_n = np.stack([-sE * sA, -sE * cA, cE], axis=-1)
        return Projection(s=s,
                          cross_track_m=np.einsum("ij,ij->i", d_n, right_n),
                          vertical_m=np.einsum("ij,ij->i", d_n, normal_n),
                          along_m=np.einsum("ij,ij->i", d_n, pt.u_n),
                          distance_m=np.linalg.norm(d_n, axis=-1), point=pt)
