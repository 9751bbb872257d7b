"""The section table: one row of a track, and the tangent geometry along a section.

A track is a sequence of **sections** starting at an origin. Within a section of length
``L`` the local along-section distance is ``t = s − s_start`` (m, ``0 <= t <= L``) and

* azimuth ``A(t) = A0 + κ0 t + (κ1 − κ0) t² / (2 L)`` (rad, clockwise from north), so the
  **curvature** ``κ(t) = dA/ds`` (1/m, positive = turning clockwise, i.e. to the right)
  changes linearly from ``κ0`` to ``κ1``: a straight (κ0 = κ1 = 0), a circular arc
  (κ0 = κ1 ≠ 0, ``|κ| = 1/R`` for the horizontal radius R) or a clothoid transition;
* elevation ``ϑ(t) = ϑ0 + (ϑ1 − ϑ0) t / L`` (rad, positive uphill): constant grade or a
  vertical curve.

``κ = dA/ds`` is the rate of the *geographic* azimuth per metre of along-track distance
``s`` (not per metre of horizontal distance). A section with constant ``A`` and ``ϑ`` is
the 2017 paper's loxodrome with exponential height (`trackmodel.loxodrome`).

The tangent in ENU is ``u_n = [cosϑ sinA, cosϑ cosA, sinϑ]`` (ARCHITECTURE.md). Its
frame-relative derivative ``du_ds_n = A' ∂u/∂A + ϑ' ∂u/∂ϑ`` is zero on a straight; the
rotation of the ENU frame itself along the track is the transport rate, handled by the
navigation equations, not here.

The table row `Section` keeps the file's units (degrees in ``*_deg`` fields) so that a
file read and written again is unchanged; `SectionArrays` holds the same table in SI
units, radians, as arrays for vectorised evaluation.

**Steps at the joints** (`joint_steps`, the one definition): where a section ends and the
next begins, ``κ`` and ``dϑ/ds`` may jump (an arc entered without a transition, the ends
of a vertical curve). The vehicle's angular rate steps there by ``v Δκ`` (the simulator
averages its IMU across such joints, `JointSteps.rate_steps_m`), and the filters' track
grid and geometry noise treat the horizontal curvature steps apart
(`JointSteps.curvature_steps_m`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from trackmodel.errors import TrackError
from trackmodel.plausibility import check_section_values

__all__ = ["Section", "SectionArrays", "MAX_ELEVATION_DEG", "tangent_frame", "JointSteps",
           "joint_steps", "JOINT_SIDE_M", "CURVATURE_STEP_1PM"]

Array = npt.NDArray[np.float64]

#: Elevations must stay strictly inside ±90° (a vertical track has no azimuth).
MAX_ELEVATION_DEG = 90.0
#: `joint_steps` evaluates the curvature this far before and after each joint, m.
JOINT_SIDE_M = 1e-6
#: A curvature change across a joint (over ±`JOINT_SIDE_M`) larger than this is a
#: curvature step, 1/m. Across ±`JOINT_SIDE_M` a continuous curvature changes by its rate
#: times 2e-6 m: ~1e-11 1/m on a rail clothoid (a 600-m curve entered over 120 m, rate
#: 1.1e-5 1/m² on ``curvy``), below the threshold; but up to 2.4e-7 1/m on the street
#: corners (radius down to 2.5 m, rates up to 0.24 1/m²) fitted to the Barcelona drive
#: (``data/tracks/barcelona_drive.csv``), so that 67 of its 119 joints count as steps
#: although its section table jumps at none (measured at stop 34; kept: the filters'
#: figures on that drive are those of this rule).
CURVATURE_STEP_1PM = 1e-9


def _finite(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise TrackError(f"{name} must be finite, got {value!r}")
    return value


@dataclass(frozen=True)
class Section:
    """One row of the section table, in the track file's units.

    Parameters
    ----------
    length_m : float
        Section length along the track, m, > 0.
    azimuth_deg : float or None
        Azimuth at the section start, degrees clockwise from north. ``None`` continues the
        previous section's end azimuth (tangent continuous); required for the first one.
    elevation_deg : float or None
        Elevation at the start, degrees, positive uphill, ``|ϑ| < 90``. ``None`` continues
        the previous section's end elevation.
    curvature_1pm : float
        Curvature ``dA/ds`` at the start, 1/m, positive = turning clockwise.
    curvature_end_1pm : float or None
        Curvature at the end, 1/m (linear change: a clothoid); ``None`` = constant.
    elevation_end_deg : float or None
        Elevation at the end, degrees (linear change: a vertical curve); ``None`` = constant.

    Raises
    ------
    TrackError
        For a non-finite value, a length <= 0 or an elevation outside (-90°, 90°);
        `trackmodel.plausibility.ImplausibleTrackError` (with the column) for a value
        beyond the plausibility limits (radius, turn, length, azimuth).
    """

    length_m: float
    azimuth_deg: float | None = None
    elevation_deg: float | None = 0.0
    curvature_1pm: float = 0.0
    curvature_end_1pm: float | None = None
    elevation_end_deg: float | None = None

    def __post_init__(self) -> None:
        if _finite("length_m", self.length_m) <= 0.0:
            raise TrackError(f"length_m must be > 0, got {float(self.length_m)!r}")
        _finite("curvature_1pm", self.curvature_1pm)
        for name in ("azimuth_deg", "curvature_end_1pm", "elevation_deg", "elevation_end_deg"):
            if getattr(self, name) is not None:
                _finite(name, getattr(self, name))
        for name in ("elevation_deg", "elevation_end_deg"):
            value = getattr(self, name)
            if value is not None and not abs(value) < MAX_ELEVATION_DEG:
                raise TrackError(f"{name} must satisfy -90 < {name} < 90, got {float(value)!r}")
        check_section_values(self)

    @property
    def curvature_end(self) -> float:
        """Curvature at the section end, 1/m (``curvature_1pm`` when not given)."""
        return self.curvature_1pm if self.curvature_end_1pm is None else self.curvature_end_1pm

    @property
    def turn_rad(self) -> float:
        """Azimuth change over the section, rad: ``L (κ0 + κ1) / 2``."""
        return 0.5 * self.length_m * (self.curvature_1pm + self.curvature_end)


@dataclass(frozen=True)
class SectionArrays:
    """The section table resolved (continuations filled in) in SI units, as arrays.

    All arrays have shape (K,) for K sections.

    Attributes
    ----------
    s_start : ndarray
        Along-track distance of each section start, m; ``s_start[0] == 0``.
    length : ndarray
        Section lengths, m.
    azimuth0, elevation0, elevation1 : ndarray
        Start azimuth (rad, in [0, 2π)), start and end elevation (rad).
    curvature0, curvature1 : ndarray
        Start and end curvature ``dA/ds``, 1/m.
    """

    s_start: Array
    length: Array
    azimuth0: Array
    elevation0: Array
    elevation1: Array
    curvature0: Array
    curvature1: Array

    @classmethod
    def resolve(cls, sections: tuple[Section, ...]) -> "SectionArrays":
        """Fill in continued azimuths/elevations and convert to radians.

        Raises
        ------
        TrackError
            If there is no section, or the first one lacks an azimuth or elevation.
        """
        if not sections:
            raise TrackError("a track needs at least one section")
        if sections[0].azimuth_deg is None or sections[0].elevation_deg is None:
            raise TrackError("the first section needs an azimuth and an elevation")
        rows = []
        azimuth = elevation = 0.0
        for sec in sections:
            azimuth = math.radians(sec.azimuth_deg) if sec.azimuth_deg is not None else azimuth
            elevation = (math.radians(sec.elevation_deg) if sec.elevation_deg is not None
                         else elevation)
            elevation_end = (elevation if sec.elevation_end_deg is None
                             else math.radians(sec.elevation_end_deg))
            rows.append((sec.length_m, azimuth % (2.0 * math.pi), elevation, elevation_end,
                         sec.curvature_1pm, sec.curvature_end))
            azimuth, elevation = azimuth + sec.turn_rad, elevation_end
        length, a0, e0, e1, k0, k1 = (np.array(col, dtype=float) for col in zip(*rows))
        s_start = np.concatenate([[0.0], np.cumsum(length)[:-1]])
        return cls(s_start, length, a0, e0, e1, k0, k1)

    @property
    def is_loxodrome(self) -> npt.NDArray[np.bool_]:
        """True for sections of constant azimuth and elevation (closed form), shape (K,)."""
        return ((self.curvature0 == 0.0) & (self.curvature1 == 0.0)
                & (self.elevation0 == self.elevation1))

    def section_of(self, s: npt.ArrayLike) -> npt.NDArray[np.intp]:
        """Section index of each ``s`` (m): the last section starting at or before it, a
        joint belonging to the next section; clipped to the table (before the start: the
        first, NaN and beyond the end: the last)."""
        k = np.searchsorted(self.s_start, s, side="right") - 1
        return np.clip(k, 0, self.s_start.size - 1)

    def angles(self, k: npt.NDArray[np.intp], t: Array) -> dict[str, Array]:
        """Azimuth, elevation and their first and second derivatives along s.

        Parameters
        ----------
        k : ndarray of int, shape (N,)
            Section index of each point.
        t : ndarray, shape (N,)
            Distance from the section start, m.

        Returns
        -------
        dict of ndarray, shape (N,)
            ``A`` (rad, wrapped to [0, 2π)), ``dA`` (1/m), ``d2A`` (1/m²), ``E`` (rad),
            ``dE`` (rad/m); the second derivative of the elevation is zero.
        """
        L = self.length[k]
        k0, k1 = self.curvature0[k], self.curvature1[k]
        d2A = (k1 - k0) / L
        A = self.azimuth0[k] + k0 * t + 0.5 * d2A * t * t
        dE = (self.elevation1[k] - self.elevation0[k]) / L
        return {"A": np.mod(A, 2.0 * np.pi), "dA": k0 + d2A * t, "d2A": d2A,
                "E": self.elevation0[k] + dE * t, "dE": dE}


def tangent_frame(A: Array, E: Array, dA: Array, dE: Array, d2A: Array, *,
                  derivatives: bool = True) -> tuple[Array, ...]:
    """ENU tangent and its first two frame-relative derivatives along s.

    Parameters
    ----------
    A, E : ndarray, shape (N,)
        Azimuth and elevation, rad.
    dA, dE : ndarray, shape (N,)
        ``dA/ds`` (1/m) and ``dϑ/ds`` (rad/m).
    d2A : ndarray, shape (N,)
        ``d²A/ds²``, 1/m² (``d²ϑ/ds² = 0`` within a section).
    derivatives : bool
        False: the tangent only (the derivatives None; ``u`` the same numbers).

    Returns
    -------
    u_n, du_ds_n, d2u_ds2_n : ndarray, shape (N, 3)
        ``u = [cosϑ sinA, cosϑ cosA, sinϑ]``, ``du/ds`` (1/m), ``d²u/ds²`` (1/m²), ENU.
    """
    sA, cA, sE, cE = np.sin(A), np.cos(A), np.sin(E), np.cos(E)
    u = _columns(cE * sA, cE * cA, sE)
    if not derivatives:
        return u, None, None
    zero = np.zeros_like(sA)
    u_A = _columns(cE * cA, -cE * sA, zero)         # ∂u/∂A
    u_E = _columns(-sE * sA, -sE * cA, cE)          # ∂u/∂ϑ
    u_AA = _columns(-cE * sA, -cE * cA, zero)       # ∂²u/∂A²
    u_AE = _columns(-sE * cA, sE * sA, zero)        # ∂²u/∂A∂ϑ
    dA, dE, d2A = (np.asarray(x, dtype=float)[..., None] for x in (dA, dE, d2A))
    du = dA * u_A + dE * u_E
    d2u = d2A * u_A + dA * dA * u_AA + 2.0 * dA * dE * u_AE - dE * dE * u   # ∂²u/∂ϑ² = −u
    return u, du, d2u


def _columns(x: Array, y: Array, z: Array) -> Array:
    """``np.stack([x, y, z], axis=-1)`` of three arrays of one shape (the same copy,
    without np.stack's generic argument handling)."""
    out = np.empty(np.shape(x) + (3,))
    out[..., 0], out[..., 1], out[..., 2] = x, y, z
    return out


@dataclass(frozen=True)
class JointSteps:
    """What steps at the joints of a section table (module docstring), J = K − 1 joints.

    Attributes
    ----------
    s_m : ndarray, shape (J,)
        Along-track distance of each joint (the next section's start), m.
    curvature_1pm : ndarray, shape (J,)
        The jump of ``κ = dA/ds`` there, the next section's ``κ0`` less the previous
        one's ``κ1``, 1/m.
    grade_rate_1pm : ndarray, shape (J,)
        The jump of ``dϑ/ds`` there, rad/m.
    curvature_across_1pm : ndarray, shape (J,)
        ``κ`` evaluated `JOINT_SIDE_M` after the joint less ``κ`` that far before it (the
        jump plus the two sections' curvature rates times the side), 1/m.
    """

    s_m: Array
    curvature_1pm: Array
    grade_rate_1pm: Array
    curvature_across_1pm: Array

    @property
    def rate_steps_m(self) -> Array:
        """``s`` of the joints where ``dA/ds`` or ``dϑ/ds`` jumps at all (the vehicle's
        angular rate steps there), m, shape (≤ J,)."""
        return self.s_m[(self.curvature_1pm != 0.0) | (self.grade_rate_1pm != 0.0)]

    @property
    def curvature_steps_m(self) -> Array:
        """``s`` of the joints where the curvature changes across the joint by more than
        `CURVATURE_STEP_1PM` (horizontal curvature steps), m, shape (≤ J,)."""
        return self.s_m[np.abs(self.curvature_across_1pm) > CURVATURE_STEP_1PM]


def joint_steps(table: SectionArrays) -> JointSteps:
    """The steps at the joints of `table` (`JointSteps`; module docstring).

    Parameters
    ----------
    table : SectionArrays

    Returns
    -------
    JointSteps
    """
    s = table.s_start[1:]
    grade_rate = (table.elevation1 - table.elevation0) / table.length
    end = float(table.s_start[-1] + table.length[-1])
    kappa = []
    for side in (-JOINT_SIDE_M, JOINT_SIDE_M):       # as `trackmodel.Track.at` finds them
        at = np.clip(s + side, 0.0, end)
        k = table.section_of(at)
        kappa.append(table.angles(k, at - table.s_start[k])["dA"])
    return JointSteps(s, table.curvature0[1:] - table.curvature1[:-1],
                      grade_rate[1:] - grade_rate[:-1], kappa[1] - kappa[0])
