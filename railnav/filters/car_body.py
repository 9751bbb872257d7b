r"""The car body as a chord between its bogies: its yaw and pitch against the track's.

A car body rests on two bogies whose pivots follow the track centre-line ``b`` apart
(``bogie_spacing_m``); its x-axis is the chord between the pivots, not the track tangent.
With the reference point (the IMU) ``d`` ahead of the body centre (``imu_offset_m``) at
track distance ``s``, the pivots are at ``s − d ± b/2``. To first order in the angle the
track turns over the chord (≤ b/R = 0.04 rad for b = 19 m, R = 475 m), the chord's azimuth is
the mean of the track azimuth over it, and its elevation the mean of the track elevation::

    A_c(s) = (1/b) ∫_{−b/2}^{b/2} A(s − d + x) dx,      δψ(s) = A_c(s) − A(s)
    dδψ/ds = (A(s − d + b/2) − A(s − d − b/2)) / b − dA/ds(s)

(the same with ϑ for the pitch offset ``δθ``). The mean-angle form differs from the chord
vector's exact direction by a third-order term, < (b/R)³/24 ≈ 3e-6 rad here.

Closed forms (the tests' references): on a constant curvature ``κ = 1/R``, ``δψ = −κ d``:
0 over the body centre and ``−b/(2R)`` over the leading bogie (``d = b/2``; the angle between a
chord of length b and the tangent at its end): 19 m on R = 600 m gives −15.8 mrad (0.91°). In
a transition where ``κ`` grows linearly (``κ' = dκ/ds``), over the centre, ``δψ = κ' b²/24``.

The mean is an `QUADRATURE_NODES`-point Gauss–Legendre quadrature; the track azimuth is taken
relative to ``A(s)`` (wrapped), so a chord across north is right. Near the track ends the
pivots are clamped to ``[0, L]``, consistently in value and derivative (the track continued
straight). The simulator (`railnav.simulation.car_body_motion`) and the attitude rows
(`railnav.filters.attitude_rows`) both use this geometry: it is the vehicle's, known to its
operator like a lever arm; the unknowns are the mounting and the suspension.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["ChordOffsets", "chord_offsets", "chord_angles", "QUADRATURE_NODES", "DEFAULT_BOGIE_SPACING_M",
           "DEFAULT_IMU_OFFSET_M"]

Array = npt.NDArray[np.float64]

#: Gauss–Legendre nodes of the chord mean (error < 1e-6 rad where a section joint, a jump
#: in dκ/ds, lies inside the chord).
QUADRATURE_NODES = 16
#: Bogie pivot spacing of a 26.4-m UIC coach / a Bo'Bo' locomotive's order of size, m.
DEFAULT_BOGIE_SPACING_M = 19.0
#: The IMU over the leading bogie (d = b/2): the largest chord offset, b/(2R).
DEFAULT_IMU_OFFSET_M = 9.5


@dataclass(frozen=True)
class ChordOffsets:
    """The body's chord attitude against the track at ``s`` (arrays shaped like ``s``).

    Attributes
    ----------
    yaw, pitch : ndarray
        ``δψ = A_c − A`` and ``δθ = ϑ_c − ϑ``, rad.
    yaw_rate_1pm, pitch_rate_1pm : ndarray
        Their derivatives along ``s``, rad/m.
    """

    yaw: Array
    pitch: Array
    yaw_rate_1pm: Array
    pitch_rate_1pm: Array


def _angles(track, s: Array) -> dict[str, Array]:
    """The track's azimuth, elevation and their rates at ``s`` clamped to the track."""
    s = np.clip(s, 0.0, track.length_m)
    k = track.section_of(s)
    return track.table.angles(k, s - track.table.s_start[k])


def _wrap(a: Array) -> Array:
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def chord_offsets(track, s: npt.ArrayLike, *, bogie_spacing_m: float = DEFAULT_BOGIE_SPACING_M,
                  imu_offset_m: float = DEFAULT_IMU_OFFSET_M) -> ChordOffsets:
    """The chord's yaw and pitch offsets from the track at ``s`` (module docstring).

    Parameters
    ----------
    track : trackmodel.Track
    s : array_like, shape (N,)
        Along-track distance of the reference point, m, in ``[0, L]``.
    bogie_spacing_m : float
        Pivot spacing ``b``, m (> 0).
    imu_offset_m : float
        Reference point ahead of the body centre, ``d``, m.

    Returns
    -------
    ChordOffsets
    """
    s = np.asarray(s, dtype=float)
    shape = s.shape
    s = s.reshape(-1)
    b, d = float(bogie_spacing_m), float(imu_offset_m)
    here = _angles(track, s)
    nodes, weights = np.polynomial.legendre.leggauss(QUADRATURE_NODES)
    x = s[:, None] - d + 0.5 * b * nodes[None, :]
    inner = _angles(track, x.reshape(-1))
    dA = _wrap(inner["A"].reshape(x.shape) - here["A"][:, None])
    dE = inner["E"].reshape(x.shape) - here["E"][:, None]
    ends = _angles(track, np.concatenate([s - d + 0.5 * b, s - d - 0.5 * b]))
    n = s.size
    yaw_rate = _wrap(ends["A"][:n] - ends["A"][n:]) / b - here["dA"]
    pitch_rate = (ends["E"][:n] - ends["E"][n:]) / b - here["dE"]
    return ChordOffsets(yaw=(0.5 * dA @ weights).reshape(shape),
                        pitch=(0.5 * dE @ weights).reshape(shape),
                        yaw_rate_1pm=yaw_rate.reshape(shape),
                        pitch_rate_1pm=pitch_rate.reshape(shape))


def chord_angles(track, s: npt.ArrayLike, *, bogie_spacing_m: float = DEFAULT_BOGIE_SPACING_M,
                 imu_offset_m: float = DEFAULT_IMU_OFFSET_M) -> tuple[Array, Array]:
    """The chord's azimuth ``A + δψ`` (in [−π, π)) and elevation ``ϑ + δθ`` at ``s``, rad
    (``s`` clamped to ``[0, L]``; arrays shaped like ``s``)."""
    s = np.clip(np.asarray(s, dtype=float), 0.0, track.length_m)
    here = _angles(track, s.reshape(-1))
    c = chord_offsets(track, s.reshape(-1), bogie_spacing_m=bogie_spacing_m,
                      imu_offset_m=imu_offset_m)
    return (_wrap(here["A"] + c.yaw).reshape(s.shape),
            (here["E"] + c.pitch).reshape(s.shape))
