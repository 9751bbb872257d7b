r"""GNSS pseudorange and range-rate rows for filters whose position is the distance ``s``.

The receiver is on the track: ``r_e = r_e(s)`` and ``v_e = v · t_e(s)`` with
``t_e = dr_e/ds = C_n_e u_n`` (ARCHITECTURE.md, "GNSS"). Each row carries the track
linearized at a reference distance ``s_ref`` (the prior's ``s`` at the epoch)::

    r_e(s) = r_ref + t_ref δ + ½ k_ref δ² + ⅙ j_ref δ³,
    t_e(s) = t_ref + k_ref δ + ½ j_ref δ²,                   δ = s − s_ref

with ``k = dt_e/ds = C_n_e (du_n/ds + ω̃ × u_n)``, ``ω̃`` the transport rate per metre of
the ENU frame (`strapdown.frames.omega_en_n` at unit speed), and ``j = dk/ds ≈ C_n_e
d²u_n/ds²`` (the curvature rate of a transition; the frame-rotation terms of ``j`` are of
order κ/R ≈ 1e-10 m⁻² and left out). The remainder is fourth order in δ. The observation equations
themselves are `gnss_obs.observables` (one implementation, shared with the SPP): this
module only composes them with ``r_e(s)`` so that CasADi differentiates through the track.
`compose_gnss_rows` is that composition for any receiver model ``(x, part) -> (r_e, v_e)``
(`railnav.filters.geodetic_rows` uses it with the unconstrained filter's geodetic position).

Row parameters (`TRACK_ROW_NAMES` then the satellite's)::

    pseudorange: [s_ref, r_ref_e (3), t_ref_e (3), k_ref_e (3), j_ref_e (3), sat_pos_e (3),
                  sat_clock_m, delays_m, system selector (one per inter-system bias state)]
    range rate:  [s_ref, r_ref_e (3), t_ref_e (3), k_ref_e (3), j_ref_e (3), sat_pos_e (3),
                  sat_vel_e (3), sat_clock_drift_mps]
"""
from __future__ import annotations

import functools
from collections.abc import Callable
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

__all__ = ["TRACK_ROW_NAMES", "GnssRows", "build_gnss_rows", "compose_gnss_rows", "track_rows",
           "pseudorange_parameters", "range_rate_parameters", "Receiver", "track_position",
           "ROW_KINDS"]

Array = npt.NDArray[np.float64]

#: Kinds of GNSS rows, as written in ``innovations.csv``.
ROW_KINDS = ("pseudorange", "range_rate")

#: The track-linearization part of every row.
TRACK_ROW_NAMES = ("s_ref", "r_ref_x", "r_ref_y", "r_ref_z", "t_x", "t_y", "t_z",
                   "k_x", "k_y", "k_z", "j_x", "j_y", "j_z")
_N_TRACK = len(TRACK_ROW_NAMES)
#: A receiver model for `compose_gnss_rows`: (state, receiver row parameters) -> (r_e, v_e).
Receiver = Callable[[ca.SX, ca.SX], tuple[ca.SX, ca.SX]]


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
    i_s, i_v = layout.index("s"), layout.index("v")

    def receiver(x: ca.SX, part: ca.SX) -> tuple[ca.SX, ca.SX]:
        r_e, t_e = track_position(part, x[i_s])
        return r_e, x[i_v] * t_e

    return compose_gnss_rows(layout, isb_names, receiver, n_part=_N_TRACK, name="track")


def compose_gnss_rows(layout: StateLayout, isb_names: tuple[str, ...], receiver: Receiver, *,
                      n_part: int, name: str) -> GnssRows:
    """Pseudorange and range-rate rows of a receiver model (`gnss_obs.observables`).

    Parameters
    ----------
    layout : ekf.StateLayout
        Must name ``clock_bias``, ``clock_drift`` and each of `isb_names`.
    isb_names : tuple of str
        Inter-system bias states (m) added to the clock bias of the satellites whose
        selector entry is 1.
    receiver : callable(x, part) -> (r_e, v_e)
        Receiver ECEF position (m) and velocity (m/s), casadi 3x1 each, from the state
        symbol ``x`` and the receiver part of the row parameters (`n_part` symbols).
    n_part : int
        Number of receiver parameters at the head of each row (0: none).
    name : str
        Prefix of the row models' names (``<name>_pseudorange``, ``<name>_range_rate``).

    Returns
    -------
    GnssRows
        Row parameters: the receiver part, then the satellite's (module docstring).
    """
    single = build_measurement_model()
    x = ca.SX.sym("x", layout.size)
    bias, drift = x[layout.index("clock_bias")], x[layout.index("clock_drift")]
    n_isb = len(isb_names)

    p_pr = ca.SX.sym("p_pr", n_part + 5 + n_isb)
    r_e, _ = receiver(x, p_pr[:n_part])
    sat_pos, sat_clock, delays = p_pr[n_part:n_part + 3], p_pr[n_part + 3], p_pr[n_part + 4]
    total_bias = bias
    for j, isb in enumerate(isb_names):
        total_bias = total_bias + p_pr[n_part + 5 + j] * x[layout.index(isb)]
    rho = single.pseudorange(r_e, total_bias, sat_pos, sat_clock, delays)[0]

    p_rr = ca.SX.sym("p_rr", n_part + 7)
    r_e2, v_e = receiver(x, p_rr[:n_part])
    rho_dot = single.range_rate(r_e2, v_e, drift, p_rr[n_part:n_part + 3],
                                p_rr[n_part + 3:n_part + 6], p_rr[n_part + 6])[0]
    return GnssRows(
        pseudorange=MeasurementModel.from_expression(x, p_pr, rho, f"{name}_pseudorange"),
        range_rate=MeasurementModel.from_expression(x, p_rr, rho_dot, f"{name}_range_rate"),
        isb_names=tuple(isb_names))


def track_position(p: ca.SX, s: ca.SX) -> tuple[ca.SX, ca.SX]:
    """``r_e(s)`` and ``t_e(s)`` from the track part of a row (module docstring; also the
    receiver of the fix rows, `railnav.filters.fix_rows`)."""
    delta = s - p[0]
    r_ref, t_ref, k_ref, j_ref = p[1:4], p[4:7], p[7:10], p[10:13]
    return (r_ref + delta * (t_ref + delta * (0.5 * k_ref + delta / 6.0 * j_ref)),
            t_ref + delta * (k_ref + 0.5 * delta * j_ref))


def track_rows(point, *, earth, C: Array | None = None) -> Array:
    """The track part of the rows at one reference point.

    Parameters
    ----------
    point : trackmodel.TrackPoint
        The track at a scalar ``s_ref``.
    earth : Ellipsoid
        The track's Earth model.
    C : ndarray, shape (3, 3), optional
        ``C_n_e(point.lat, point.lon)`` if the caller has it already.

    Returns
    -------
    ndarray, shape (13,)
        ``[s_ref, r_ref_e, t_ref_e, k_ref_e, j_ref_e]`` (m, m, 1, 1/m, 1/m²), ECEF.
    """
    if C is None:
        C = C_n_e(point.lat, point.lon)
    u_n = np.asarray(point.u_n, dtype=float)
    rate_per_m = omega_en_n(u_n, float(point.lat), float(point.h), earth=earth)
    out = np.empty(13)                  # (np.concatenate of the parts, without the lists)
    out[0] = float(point.s)
    out[1:4] = np.asarray(point.r_e, dtype=float)
    out[4:7] = C @ u_n
    out[7:10] = C @ (np.asarray(point.du_ds_n, dtype=float) + _cross3(rate_per_m, u_n))
    out[10:13] = C @ np.asarray(point.d2u_ds2_n, dtype=float)
    return out


def _cross3(a: Array, b: Array) -> Array:
    """``np.cross(a, b)`` of two 3-vectors, the same products and differences in the same
    order (the same bits), without `np.cross`'s generic axis handling (~10 µs a call)."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def pseudorange_parameters(track_part: Array, prepared: PreparedEpoch,
                           isb_systems: tuple[str, ...]) -> Array:
    """Pseudorange row parameters, one row per satellite of `prepared`.

    Parameters
    ----------
    track_part : ndarray, shape (k,)
        The receiver part of the rows: `track_rows` (k = 10), or empty for receiver models
        without parameters (`compose_gnss_rows`).
    prepared : gnss_obs.PreparedEpoch
    isb_systems : tuple of str
        System letters of the inter-system bias states, in the layout's order.

    Returns
    -------
    ndarray, shape (N, k + 5 + len(isb_systems))
    """
    part = _receiver_part(track_part)
    k, n = part.size, len(prepared)
    out = np.empty((n, k + 5 + len(isb_systems)))
    out[:, :k] = part
    out[:, k:k + 3] = prepared.sat_pos_e
    out[:, k + 3] = prepared.sat_clock_m
    out[:, k + 4] = prepared.delays_m
    if isb_systems:
        out[:, k + 5:] = np.asarray(prepared.system)[:, None] == \
            np.array(isb_systems, dtype=object)[None, :]
    return out


def range_rate_parameters(track_part: Array, prepared: PreparedEpoch) -> Array:
    """Range-rate row parameters, one row per satellite of `prepared`, shape (N, k + 7)
    (``track_part`` as in `pseudorange_parameters`)."""
    part = _receiver_part(track_part)
    k = part.size
    out = np.empty((len(prepared), k + 7))
    out[:, :k] = part
    out[:, k:k + 3] = prepared.sat_pos_e
    out[:, k + 3:k + 6] = prepared.sat_vel_e
    out[:, k + 6] = prepared.sat_clock_drift_mps
    return out


def _receiver_part(part: Array) -> Array:
    """The receiver part of the rows, shape (k,) (each row's first k parameters)."""
    return np.asarray(part, dtype=float).reshape(-1)
