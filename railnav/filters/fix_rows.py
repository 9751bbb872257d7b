r"""GNSS fix rows (loose coupling): a position fix, and its velocity, as observations of
``s`` and ``v`` through the track geometry.

The receiver is on the track, ``r_e(s)`` (`railnav.filters.gnss_rows.track_position`: the
track expanded to third order about the prior's ``s_ref``). A fix ``r_fix`` is compared
with it along fixed unit vectors ``a`` of the track frame at ``s_ref`` (ENU; ARCHITECTURE
conventions, as `trackmodel.project` measures offsets)::

    z = aᵀ C_e_n (r_fix − r_ref),        h(x) = aᵀ C_e_n (r_e(s) − r_ref)

* ``fix_along``: ``a`` the tangent ``u = [cosϑ sinA, cosϑ cosA, sinϑ]``, or its horizontal
  direction ``[sinA, cosA, 0]`` for a fix without height; ``∂h/∂s ≈ |a·u|``: this row
  carries the fix's information on ``s``;
* ``fix_cross``: ``a = [cosA, −sinA, 0]`` (right of +s); ``∂h/∂s = 0`` at ``s_ref``: it
  measures how far the fix is from the track, so the fault screen can reject a fix that
  is off the track but near the prior along it;
* ``fix_up`` (fixes with an ellipsoidal height, ``FixModelConfig.use_height``): ``a`` the
  up-normal ``[−sinϑ sinA, −sinϑ cosA, cosϑ]``;
* ``fix_speed`` (fixes with a velocity, or a speed and a course): ``z = aᵀ v_fix_n`` with
  ``a`` the tangent (3-D velocity) or its horizontal direction, ``h(x) = v aᵀ C_e_n t_e(s)``.

Noise: ``R = aᵀ Σ_fix a`` (+ ``track_cross_sigma_m²`` on the cross row,
``track_vertical_sigma_m²`` on the up row); the rows of one fix are taken as
uncorrelated (the covariance ``aᵀ Σ b`` between rows is left out: the row screen needs
diagonal R, and it is zero for a fix whose horizontal σ are equal). The rows of a fix are
one group in the fault screen (`railnav.filters.fault_detection.RowScreen`): a fix is used
whole or not at all, each row tested at the prior, without channel memory (a fix's error
is not a satellite channel's; the cross-track row carries the map's constant offsets).

Row parameters: ``[s_ref, r_ref_e (3), t_ref_e (3), k_ref_e (3), j_ref_e (3), a_e (3)]``
(the track part of `railnav.filters.gnss_rows.track_rows`, then the axis in ECEF).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.model import MeasurementModel
from ekf.update import Observation
from railnav.filters.fix_epochs import FixEpochs, FixModelConfig
from railnav.filters.gnss_rows import TRACK_ROW_NAMES, track_position, track_rows
from railnav.filters.track_frame import antenna_track_part, track_axes_n
from trackmodel.earth import C_n_e, geodetic_to_ecef

__all__ = ["FixRows", "build_fix_rows", "FixRowBuilder", "FIX_ROW_KINDS", "track_axes_n",
           "FIX_SV_PREFIX", "stack_epoch_rows"]

Array = npt.NDArray[np.float64]

#: Kinds of fix rows, as written in ``innovations.csv``.
FIX_ROW_KINDS = ("fix_along", "fix_cross", "fix_up", "fix_speed")
#: ``innovations.csv`` ``sv`` of a fix row: this prefix and the fix class.
FIX_SV_PREFIX = "fix:"
_N_TRACK = len(TRACK_ROW_NAMES)


@dataclass(frozen=True, eq=False)
class FixRows:
    """Fix row models of a state layout.

    Attributes
    ----------
    position, speed : ekf.MeasurementModel
        Scalar rows, parameters as in the module docstring.
    """

    position: MeasurementModel
    speed: MeasurementModel


@functools.lru_cache(maxsize=None)
def build_fix_rows(layout: StateLayout) -> FixRows:
    """Fix row models for a layout with states ``s`` and ``v``.

    Returns
    -------
    FixRows
    """
    x = ca.SX.sym("x", layout.size)
    s, v = x[layout.index("s")], x[layout.index("v")]
    p = ca.SX.sym("p", _N_TRACK + 3)
    r_e, t_e = track_position(p[:_N_TRACK], s)
    axis = p[_N_TRACK:]
    along = ca.dot(axis, r_e - p[1:4])
    speed = v * ca.dot(axis, t_e)
    return FixRows(position=MeasurementModel.from_expression(x, p, along, "fix_position"),
                   speed=MeasurementModel.from_expression(x, p, speed, "fix_speed"))


class FixRowBuilder:
    """The rows of each fix at the prior's point on the track.

    Parameters
    ----------
    track : trackmodel.Track
    layout : ekf.StateLayout
        With states ``s`` and ``v``.
    fixes : FixEpochs
    config : FixModelConfig
    antenna_m : (float, float, float)
        The antenna's lever arm (forward, left, up; `railnav.filters.track_frame`): the
        rows are those of the antenna's point.
    """

    def __init__(self, track, layout: StateLayout, fixes: FixEpochs,
                 config: FixModelConfig, *, antenna_m=(0.0, 0.0, 0.0)) -> None:
        self.track, self.fixes, self.config = track, fixes, config
        self.antenna_m = tuple(antenna_m)
        self.rows = build_fix_rows(layout)
        self.i_s = layout.index("s")

    def observations(self, index: int, x: Array) -> tuple[list[Observation], np.ndarray,
                                                          np.ndarray]:
        """The rows of fix `index` at the prior state ``x``.

        Returns
        -------
        observations : list of ekf.Observation
            Scalar rows, variances (module docstring).
        sv, kind : ndarray of str, shape (m,)
            ``fix:<class>`` and the `FIX_ROW_KINDS` of each row.
        """
        s = min(max(float(x[self.i_s]), 0.0), self.track.length_m)
        point = self.track.at(s)
        C = C_n_e(point.lat, point.lon)
        part = track_rows(point, earth=self.track.earth, C=C)
        if any(self.antenna_m):
            part = antenna_track_part(self.track, part, self.antenna_m)
        f, cfg = self.fixes, self.config
        has_h = cfg.use_height and bool(np.isfinite(f.h_m[index]))
        h = f.h_m[index] if has_h else float(point.h) + self.antenna_m[2]
        d_n = C.T @ (geodetic_to_ecef(f.lat[index], f.lon[index], h, earth=self.track.earth)
                     - part[1:4])
        axes = track_axes_n(point)
        cov = f.cov_n_m2[index]
        extra = {"fix_along": 0.0, "fix_cross": cfg.track_cross_sigma_m ** 2,
                 "fix_up": cfg.track_vertical_sigma_m ** 2}
        names = {"fix_along": "along" if has_h else "along_h", "fix_cross": "cross",
                 "fix_up": "up"}
        kinds = [k for k in ("fix_along", "fix_cross", "fix_up") if k != "fix_up" or has_h]
        z, R = np.empty((len(kinds), 1)), np.empty(len(kinds))
        p = np.empty((len(kinds), part.size + 3))       # each row [part, C a], filled in place
        p[:, :part.size] = part
        for i, kind in enumerate(kinds):
            a = axes[names[kind]]
            z[i, 0] = a @ d_n
            R[i] = a @ cov @ a + extra[kind]
            p[i, part.size:] = C @ a
        obs = [Observation(self.rows.position, z, R, p)]
        speed = self._speed_row(index, part, C, axes)
        if speed is not None:
            obs.append(speed)
            kinds.append("fix_speed")
        sv = np.full(len(kinds), FIX_SV_PREFIX + str(f.quality[index]), dtype=object)
        return obs, sv, np.array(kinds, dtype=object)

    def _speed_row(self, index: int, part: Array, C: Array, axes: dict) -> Observation | None:
        v = self.fixes.v_n_mps[index]
        if not self.config.use_speed or not np.all(np.isfinite(v[:2])):
            return None
        a = axes["along"] if np.isfinite(v[2]) else axes["along_h"]
        z = float(a @ np.nan_to_num(v))
        R = float(self.fixes.sigma_speed_mps[index]) ** 2
        return Observation(self.rows.speed, np.array([[z]]), np.array([R]),
                           np.concatenate([part, C @ a])[None, :])


def stack_epoch_rows(gnss, fix, *, gnss_mode: str, fix_group: int, extra=()):
    """One epoch's GNSS rows and fix rows (and other sensors' rows), stacked for the fault
    screen.

    Parameters
    ----------
    gnss, fix : (list of ekf.Observation, sv, kind) or None
        The GNSS rows (`railnav.filters.common.GnssRowBuilder`) and the fix rows
        (`FixRowBuilder.observations`) of the epoch.
    gnss_mode : str
        Screen mode of the GNSS rows (`railnav.filters.fault_detection.SCREEN_MODES`);
        the fix rows are screened ``row`` by row.
    fix_group : int
        Group of the fix rows (they are used together).
    extra : sequence of ((list of ekf.Observation, sv, kind), mode)
        Other rows with their screen mode, in no group (the odometer and balise rows,
        `railnav.filters.sensor_rows.SensorRows.parts`).

    Returns
    -------
    observations, sv, kind, modes, groups
        The arguments of `railnav.filters.fault_detection.RowScreen.screen`.
    """
    obs, sv, kind, modes, groups = [], [], [], [], []
    parts = [(gnss, gnss_mode, -1), (fix, "row", fix_group)]
    parts += [(part, mode, -1) for part, mode in extra]
    for part, mode, group in parts:
        if part is None:
            continue
        rows, labels, kinds = part
        obs += list(rows)
        sv.append(np.asarray(labels, dtype=object))
        kind.append(np.asarray(kinds, dtype=object))
        modes.append(_filled(len(labels), mode, object))
        groups.append(_filled(len(labels), group, np.intp))
    if not sv:
        empty = np.zeros(0, dtype=object)
        return obs, empty, empty, empty, np.zeros(0, dtype=np.intp)
    if len(sv) == 1:                         # one part (GNSS rows alone): as they are
        return obs, sv[0], kind[0], modes[0], groups[0]
    return (obs, np.concatenate(sv), np.concatenate(kind), np.concatenate(modes),
            np.concatenate(groups))


@functools.lru_cache(maxsize=256)
def _filled(n: int, value, dtype) -> np.ndarray:
    """``np.full(n, value, dtype=dtype)``, read only (shared by the epochs)."""
    out = np.full(n, value, dtype=dtype)
    out.flags.writeable = False
    return out
