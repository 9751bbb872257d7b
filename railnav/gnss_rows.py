r"""GNSS pseudorange and range-rate rows for filters whose position is the distance ``s``.

The receiver is on the track: ``r_e = r_e(s)`` and ``v_e = v · t_e(s)`` with
``t_e = dr_e/ds = C_n_e u_n`` (ARCHITECTURE.md, "GNSS"). Each row carries the track
linearized at a reference distance ``s_ref`` (the prior's ``s`` at the epoch)::

    r_e(s) = r_ref + t_ref δ + ½ k_ref δ²,    t_e(s) = t_ref + k_ref δ,    δ = s − s_ref

with ``k = dt_e/ds = C_n_e (du_n/ds + ω̃ × u_n)``, ``ω̃`` the transport rate per metre of
the ENU frame (`strapdown.frames.omega_en_n` at unit speed). The observation equations
themselves are `gnss_obs.observables` (one implementation, shared with the SPP): this
module only composes them with ``r_e(s)`` so that CasADi differentiates through the track.

Row parameters (`TRACK_ROW_NAMES` then the satellite's)::

    pseudorange: [s_ref, r_ref_e (3), t_ref_e (3), k_ref_e (3), sat_pos_e (3), sat_clock_m,
                  delays_m, system selector (one per inter-system bias state)]
    range rate:  [s_ref, r_ref_e (3), t_ref_e (3), k_ref_e (3), sat_pos_e (3), sat_vel_e (3),
                  sat_clock_drift_mps]
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.model import MeasurementModel
from gnss_obs.epoch import PreparedEpoch
from gnss_obs.observables import build_measurement_model
from strapdown.frames import omega_en_n
from trackmodel.earth import C_n_e

__all__ = ["TRACK_ROW_NAMES", "GnssRows", "build_gnss_rows", "track_rows",
           "pseudorange_parameters", "range_rate_parameters"]

Array = npt.NDArray[np.float64]

#: The track-linearization part of every row.
TRACK_ROW_NAMES = ("s_ref", "r_ref_x", "r_ref_y", "r_ref_z", "t_x", "t_y", "t_z",
                   "k_x", "k_y", "k_z")
_N_TRACK = len(TRACK_ROW_NAMES)


@dataclass(frozen=True, eq=False)
class GnssRows:
    """Pseudorange and range-rate row models of a state layout.

    Attributes
    ----------
    pseudorange, range_rate : ekf.MeasurementModel
    isb_names : tuple of str
        The inter-system bias states the pseudorange selector addresses, in order.
    """

    pseudorange: MeasurementModel
    range_rate: MeasurementModel
    isb_names: tuple[str, ...]


@functools.lru_cache(maxsize=None)
def build_gnss_rows(layout: StateLayout, isb_names: tuple[str, ...] = ()) -> GnssRows:
    """Row models for a layout with states ``s, v, clock_bias, clock_drift`` (+ ISBs).

    Parameters
    ----------
    layout : ekf.StateLayout
        Must name ``s``, ``v``, ``clock_bias``, ``clock_drift`` and each of `isb_names`.
    isb_names : tuple of str
        Inter-system bias states (m) added to the clock bias of the satellites whose
        selector entry is 1.

    Returns
    -------
    GnssRows
    """
    single = build_measurement_model()
    x = ca.SX.sym("x", layout.size)
    s, v = x[layout.index("s")], x[layout.index("v")]
    bias, drift = x[layout.index("clock_bias")], x[layout.index("clock_drift")]
    n_isb = len(isb_names)

    p_pr = ca.SX.sym("p_pr", _N_TRACK + 5 + n_isb)
    r_e, _ = _track_position(p_pr, s)
    sat_pos, sat_clock, delays = p_pr[_N_TRACK:_N_TRACK + 3], p_pr[_N_TRACK + 3], \
        p_pr[_N_TRACK + 4]
    total_bias = bias
    for j, name in enumerate(isb_names):
        total_bias = total_bias + p_pr[_N_TRACK + 5 + j] * x[layout.index(name)]
    rho = single.pseudorange(r_e, total_bias, sat_pos, sat_clock, delays)[0]

    p_rr = ca.SX.sym("p_rr", _N_TRACK + 7)
    r_e2, t_e = _track_position(p_rr, s)
    rho_dot = single.range_rate(r_e2, v * t_e, drift, p_rr[_N_TRACK:_N_TRACK + 3],
                                p_rr[_N_TRACK + 3:_N_TRACK + 6], p_rr[_N_TRACK + 6])[0]
    return GnssRows(
        pseudorange=MeasurementModel.from_expression(x, p_pr, rho, "track_pseudorange"),
        range_rate=MeasurementModel.from_expression(x, p_rr, rho_dot, "track_range_rate"),
        isb_names=tuple(isb_names))


def _track_position(p: ca.SX, s: ca.SX) -> tuple[ca.SX, ca.SX]:
    """``r_e(s)`` and ``t_e(s)`` from the track part of a row (module docstring)."""
    delta = s - p[0]
    r_ref, t_ref, k_ref = p[1:4], p[4:7], p[7:10]
    return r_ref + t_ref * delta + 0.5 * k_ref * delta * delta, t_ref + k_ref * delta


def track_rows(point, *, earth) -> Array:
    """The track part of the rows at one reference point.

    Parameters
    ----------
    point : trackmodel.TrackPoint
        The track at a scalar ``s_ref``.
    earth : Ellipsoid
        The track's Earth model.

    Returns
    -------
    ndarray, shape (10,)
        ``[s_ref, r_ref_e, t_ref_e, k_ref_e]`` (m, m, 1, 1/m), ECEF.
    """
    C = C_n_e(point.lat, point.lon)
    u_n = np.asarray(point.u_n, dtype=float)
    rate_per_m = omega_en_n(u_n, float(point.lat), float(point.h), earth=earth)
    k_e = C @ (np.asarray(point.du_ds_n, dtype=float) + np.cross(rate_per_m, u_n))
    return np.concatenate([[float(point.s)], np.asarray(point.r_e, dtype=float), C @ u_n, k_e])


def pseudorange_parameters(track_part: Array, prepared: PreparedEpoch,
                           isb_systems: tuple[str, ...]) -> Array:
    """Pseudorange row parameters, one row per satellite of `prepared`.

    Parameters
    ----------
    track_part : ndarray, shape (10,)
        From `track_rows`.
    prepared : gnss_obs.PreparedEpoch
    isb_systems : tuple of str
        System letters of the inter-system bias states, in the layout's order.

    Returns
    -------
    ndarray, shape (N, 15 + len(isb_systems))
    """
    n = len(prepared)
    selector = (np.asarray(prepared.system)[:, None] == np.array(isb_systems, dtype=object)[None, :]
                ).astype(float) if isb_systems else np.zeros((n, 0))
    return np.column_stack([np.broadcast_to(track_part, (n, _N_TRACK)), prepared.sat_pos_e,
                            prepared.sat_clock_m, prepared.delays_m, selector])


def range_rate_parameters(track_part: Array, prepared: PreparedEpoch) -> Array:
    """Range-rate row parameters, one row per satellite of `prepared`, shape (N, 17)."""
    n = len(prepared)
    return np.column_stack([np.broadcast_to(track_part, (n, _N_TRACK)), prepared.sat_pos_e,
                            prepared.sat_vel_e, prepared.sat_clock_drift_mps])
