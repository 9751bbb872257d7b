r"""The exact trajectory of a train on a track, and its ideal (error-free) IMU record.

`simulate_truth` evaluates a `SpeedProfile` at the IMU sample times and places the
vehicle on the track: ``s(t)``, ``v(t)``, ``a(t)`` from the profile; position, tangent
and curvature from ``Track.at(s)``; attitude yaw = track azimuth, pitch = track
elevation, roll = 0 (the track model has no cant).

`ideal_imu` derives the specific force and inertial angular rate **in the ECEF frame,
independently of the navigation-frame mechanization** (no Euler-rate matrix, no
transport rate, no ENU Coriolis term), so that it can prove the mechanizations right::

    r_e' = dr_e/ds = C_n_e u_n                       (track contract)
    r_e''          = (∂C_n_e/∂φ φ' + ∂C_n_e/∂λ λ') u_n + C_n_e du_ds_n,
                     φ' = u_N/(R_M + h),  λ' = u_E/((R_N + h) cos φ)
    ṙ_e = v r_e',   r̈_e = a r_e' + v² r_e''
    f_e = r̈_e + 2 Ω_e × ṙ_e − g_e,     g_e = C_n_e g_n(φ, h)   (normal gravity)
    C_b_e = C_n_e(φ, λ) C_b_n(A, ϑ, 0),  Ċ_b_e = v (C_n_e' C_b_n + C_n_e (∂C_b_n/∂ψ A' + ∂C_b_n/∂θ ϑ'))
    [ω_eb_b ×] = C_b_eᵀ Ċ_b_e,   ω_ib_b = C_b_eᵀ Ω_e + ω_eb_b,   f_b = C_b_eᵀ f_e

``∂C_n_e/∂φ, ∂C_n_e/∂λ`` are written out below; ``∂C_b_n/∂ψ, ∂C_b_n/∂θ`` come from CasADi
differentiating `strapdown.euler.C_b_n` (the attitude convention's one owner). Only
normal gravity (`strapdown.gravity`) is shared with the mechanizations: it is the model,
not the method.
"""
from __future__ import annotations

import functools
import math
from collections.abc import Iterator
from dataclasses import dataclass, fields

import casadi as ca
import numpy as np
import numpy.typing as npt
import pandas as pd

from railnav.errors import ConfigError
from railnav.simulation.profiles import SpeedProfile
from strapdown.backend import batch_call
from strapdown.euler import C_b_n
from strapdown.gravity import g_n
from strapdown.imu import Imu
from trackmodel.earth import C_n_e, radii
from trackmodel.track import TrackPoint

__all__ = ["Truth", "TRUTH_COLUMNS", "simulate_truth", "simulate_truth_with_points",
           "iter_truth", "iter_truth_with_points", "truth_at", "ideal_imu"]

Array = npt.NDArray[np.float64]

#: Column names of truth.csv, in order.
TRUTH_COLUMNS = ("time_s", "s_m", "lat_deg", "lon_deg", "h_m", "speed_mps", "yaw_deg",
                 "pitch_deg", "roll_deg")


@dataclass(frozen=True)
class Truth:
    """The true trajectory at the sample times (all arrays have N rows).

    Attributes
    ----------
    time_s : ndarray, (N,)
        Time since the start of the trip, s.
    s, v, a : ndarray, (N,)
        Along-track distance (m), speed ds/dt (m/s), acceleration dv/dt (m/s²).
    lat, lon : ndarray, (N,)
        Geodetic latitude and longitude, rad.
    h : ndarray, (N,)
        Ellipsoidal height, m.
    r_e : ndarray, (N, 3)
        ECEF position, m.
    v_n : ndarray, (N, 3)
        Velocity relative to the Earth in ENU, m/s (``v u_n``).
    yaw, pitch, roll : ndarray, (N,)
        Euler angles of the body relative to ENU (`strapdown.euler`), rad.
    """

    time_s: Array
    s: Array
    v: Array
    a: Array
    lat: Array
    lon: Array
    h: Array
    r_e: Array
    v_n: Array
    yaw: Array
    pitch: Array
    roll: Array

    @property
    def v_e(self) -> Array:
        """Velocity relative to the Earth in ECEF, m/s, (N, 3)."""
        return np.einsum("...ij,...j->...i", C_n_e(self.lat, self.lon), self.v_n)

    def rows(self, index: npt.ArrayLike | slice) -> "Truth":
        """The samples `index` (integers, booleans or a slice) of every `Truth` field (a
        subclass's own fields are left out)."""
        return Truth(**{f.name: getattr(self, f.name)[index] for f in fields(Truth)})

    def full_state(self) -> Array:
        """True states of the 9-state model (`strapdown.mechanization.FULL_STATE_NAMES`), (N, 9)."""
        return np.column_stack([self.yaw, self.pitch, self.roll, self.v_n, self.lat, self.lon,
                                self.h])

    def reduced_state(self) -> Array:
        """True states of the reduced model (`strapdown.reduced.REDUCED_STATE_NAMES`), (N, 5)."""
        return np.column_stack([self.yaw, self.pitch, self.roll, self.s, self.v])

    def to_frame(self) -> pd.DataFrame:
        """The truth.csv table (columns `TRUTH_COLUMNS`, angles in degrees)."""
        deg = np.degrees
        return pd.DataFrame(dict(zip(TRUTH_COLUMNS, (
            self.time_s, self.s, deg(self.lat), deg(self.lon), self.h, self.v,
            deg(self.yaw), deg(self.pitch), deg(self.roll)))))


def simulate_truth(track, profile: SpeedProfile, *, duration_s: float, rate_hz: float = 100.0,
                   start_s: float = 0.0) -> Truth:
    """Sample the trajectory of `profile` on `track` at `rate_hz`.

    Parameters
    ----------
    track : trackmodel.Track
    profile : SpeedProfile
        Speed versus time (the distance starts at `start_s`).
    duration_s : float
        Trip duration, s; the trip ends earlier at the last sample still on the track.
    rate_hz : float
        Sample rate, Hz (samples at ``k / rate_hz``).
    start_s : float
        Along-track distance at t = 0, m.

    Returns
    -------
    Truth

    Raises
    ------
    ConfigError
        For non-positive duration or rate, or a start outside the track.
    """
    return simulate_truth_with_points(track, profile, duration_s=duration_s, rate_hz=rate_hz,
                                      start_s=start_s)[0]


def simulate_truth_with_points(track, profile: SpeedProfile, *, duration_s: float,
                               rate_hz: float = 100.0, start_s: float = 0.0
                               ) -> tuple[Truth, TrackPoint]:
    """`simulate_truth`, and the track at its samples (``track.at(truth.s)``), which
    `ideal_imu` takes as ``point`` instead of evaluating the track a second time."""
    n = _sample_count(track, duration_s=duration_s, rate_hz=rate_hz, start_s=start_s)
    truth, _, point = _truth_block(track, profile, 0, n, rate_hz=rate_hz, start_s=start_s)
    _check_two_samples(truth)
    return truth, point


def iter_truth(track, profile: SpeedProfile, *, duration_s: float, rate_hz: float = 100.0,
               start_s: float = 0.0, block_size: int) -> Iterator[Truth]:
    """`simulate_truth` in consecutive blocks, for trips too long to hold in memory.

    The blocks' concatenation equals ``simulate_truth(...)`` sample for sample: each sample
    ``k`` is evaluated at ``k / rate_hz`` by the same code, and the trip ends at the same
    sample when it reaches the track end.

    Parameters
    ----------
    track, profile, duration_s, rate_hz, start_s
        As for `simulate_truth`.
    block_size : int
        Samples per block (>= 2); the last block may be shorter.

    Yields
    ------
    Truth
        Samples ``[k0, k0 + block_size)`` of the trip.

    Raises
    ------
    ConfigError
        As `simulate_truth`, or for a block size below 2.
    """
    for block, _ in iter_truth_with_points(track, profile, duration_s=duration_s,
                                           rate_hz=rate_hz, start_s=start_s,
                                           block_size=block_size):
        yield block


def iter_truth_with_points(track, profile: SpeedProfile, *, duration_s: float,
                           rate_hz: float = 100.0, start_s: float = 0.0, block_size: int
                           ) -> Iterator[tuple[Truth, TrackPoint]]:
    """`iter_truth`'s blocks, each with the track at its samples (as
    `simulate_truth_with_points`)."""
    if not (isinstance(block_size, (int, np.integer)) and block_size >= 2):
        raise ConfigError(f"block_size must be an integer >= 2, got {block_size!r}")
    n = _sample_count(track, duration_s=duration_s, rate_hz=rate_hz, start_s=start_s)
    for k0 in range(0, n, block_size):
        block, ended, point = _truth_block(track, profile, k0, min(k0 + block_size, n),
                                           rate_hz=rate_hz, start_s=start_s)
        if k0 == 0:
            _check_two_samples(block)
        if block.time_s.size:
            yield block, point
        if ended:
            return


def _sample_count(track, *, duration_s: float, rate_hz: float, start_s: float) -> int:
    """Number of samples of a trip of `duration_s` (validating the arguments)."""
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ConfigError(f"duration_s must be finite and > 0, got {duration_s!r}")
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise ConfigError(f"rate_hz must be finite and > 0, got {rate_hz!r}")
    if not 0.0 <= start_s < track.length_m:
        raise ConfigError(f"start_s must satisfy 0 <= start_s < {track.length_m} m")
    return int(math.floor(duration_s * rate_hz + 1e-9)) + 1


def _check_two_samples(truth: Truth) -> None:
    if truth.time_s.size < 2:
        raise ConfigError("the trip leaves the track before its second sample")


def _truth_block(track, profile: SpeedProfile, k0: int, k1: int, *, rate_hz: float,
                 start_s: float) -> tuple[Truth, bool, TrackPoint]:
    """Samples ``k0 <= k < k1`` up to the first beyond the track end; whether the trip
    ended there (a sample was beyond the end); the track at the samples."""
    return _truth_and_point(track, profile, np.arange(k0, k1) / rate_hz, start_s=start_s)


def truth_at(track, profile: SpeedProfile, time_s: Array, *, start_s: float = 0.0
             ) -> tuple[Truth, bool]:
    """The trajectory at increasing times `time_s` (s), up to the first beyond the track
    end; and whether the trip ended there (the sample grid of `simulate_truth`, or any
    other: the jittered instants of a simulated IMU log, `railnav.simulation.imu_logs`)."""
    truth, ended, _ = _truth_and_point(track, profile, time_s, start_s=start_s)
    return truth, ended


def _truth_and_point(track, profile: SpeedProfile, time_s: Array, *, start_s: float
                     ) -> tuple[Truth, bool, TrackPoint]:
    """`truth_at`, and the track point of each sample kept (``track.at(truth.s)``)."""
    sample = profile.evaluate(np.asarray(time_s, dtype=float))
    s = start_s + sample.s
    keep = s <= track.length_m
    keep = keep & (np.cumsum(~keep) == 0)  # stop at the first sample past the end
    pt = track.at(s[keep])
    v = sample.v[keep]
    zero = np.zeros_like(v)
    truth = Truth(time_s=sample.time_s[keep], s=pt.s, v=v, a=sample.a[keep], lat=pt.lat,
                  lon=pt.lon, h=pt.h, r_e=pt.r_e, v_n=v[:, None] * pt.u_n, yaw=pt.azimuth,
                  pitch=pt.elevation, roll=zero)
    return truth, not bool(keep.all()), pt


def _dC_n_e_ds(C_ne: Array, dlat_ds: Array, dlon_ds: Array) -> Array:
    """``dC_n_e/ds = ∂C_n_e/∂lat · dlat/ds + ∂C_n_e/∂lon · dlon/ds``, (N, 3, 3), from
    `trackmodel.earth.C_n_e`'s own entries: its partials are its entries up to sign
    (``∂/∂lat`` has the columns ``(0, −up, north)``, ``∂/∂lon`` the rows
    ``(−row₁, row₀, 0)``), so no sine or cosine is evaluated again. Each entry is
    ``a·dlat/ds + b·dlon/ds`` with the partials' entries ``a``, ``b``, zeros included (for
    the signs of zeros): the bits of the stacked product and sum."""
    zero_lat, zero_lon = 0.0 * dlat_ds, 0.0 * dlon_ds
    lat_terms = (lambda i: zero_lat, lambda i: -C_ne[..., i, 2] * dlat_ds,
                 lambda i: C_ne[..., i, 1] * dlat_ds)                  # by column
    lon_terms = (lambda j: -C_ne[..., 1, j] * dlon_ds, lambda j: C_ne[..., 0, j] * dlon_ds,
                 lambda j: zero_lon)                                   # by row
    out = np.empty(C_ne.shape)
    for i in range(3):
        for j in range(3):
            np.add(lat_terms[j](i), lon_terms[i](j), out=out[..., i, j])
    return out


@functools.lru_cache(maxsize=1)
def _dC_b_n_function() -> ca.Function:
    """CasADi: angles (3) -> [vec(∂C_b_n/∂yaw), vec(∂C_b_n/∂pitch), vec(∂C_b_n/∂roll)]
    (27), column-major."""
    ang = ca.SX.sym("angles", 3)
    C = ca.reshape(C_b_n(ang[0], ang[1], ang[2]), 9, 1)
    J = ca.jacobian(C, ang)
    return ca.Function("dC_b_n", [ang], [ca.vertcat(J[:, 0], J[:, 1], J[:, 2])])


def _attitude_matrices(truth: Truth, rates: Array) -> tuple[Array, Array]:
    """``C_b_n`` at the truth's Euler angles and its derivative ``Σ_i ∂C_b_n/∂α_i ρ_i``
    for the angle rates ``ρ`` (N, k; k = 2: yaw and pitch, or 3), both (N, 3, 3).

    Evaluated once per run of bit-equal consecutive rows of angles and rates (a straight
    section's attitude is constant) and repeated: the same values as row by row.
    """
    key = np.column_stack([truth.yaw, truth.pitch, truth.roll, rates])
    bits = key.view(np.int64)
    new = np.ones(key.shape[0], dtype=bool)
    new[1:] = np.any(bits[1:] != bits[:-1], axis=1)
    first = key if new.all() else key[new]
    C_bn = C_b_n(first[:, 0], first[:, 1], first[:, 2])
    (dC,) = batch_call(_dC_b_n_function(), first[:, :3])
    terms = [dC[:, 9 * i:9 * i + 9].reshape(-1, 3, 3).transpose(0, 2, 1)
             * first[:, 3 + i, None, None] for i in range(rates.shape[1])]
    dC_bn = sum(terms[1:], terms[0])
    if first is key:
        return C_bn, dC_bn
    row = np.cumsum(new) - 1
    return C_bn[row], dC_bn[row]


def ideal_imu(track, truth: Truth, *, attitude_rates: Array | None = None,
              point: TrackPoint | None = None) -> Imu:
    """Error-free specific force and inertial angular rate in body axes (module docstring).

    Parameters
    ----------
    track : trackmodel.Track
        The track `truth` was simulated on (its Earth model sets Ω and gravity).
    truth : Truth
    attitude_rates : ndarray, shape (N, 3), optional
        ``[ψ̇, θ̇, φ̇]`` of the body, rad/s, when its attitude is not the track's (a car
        body's chord and suspension, `railnav.simulation.car_body_motion`); default: the
        track's, ``v (dA/ds, dϑ/ds, 0)``.
    point : trackmodel.TrackPoint, optional
        ``track.at(truth.s)`` when the caller has it (`simulate_truth_with_points`); by
        default the track is evaluated here.

    Returns
    -------
    Imu
        Instantaneous values at ``truth.time_s``.
    """
    earth = track.earth
    pt = track.at(truth.s) if point is None else point
    lat, lon, h, u_n = pt.lat, pt.lon, pt.h, pt.u_n
    mv = lambda M, x: np.einsum("...ij,...j->...i", M, x)  # noqa: E731
    C_ne = C_n_e(lat, lon)
    R_M, R_N = radii(lat, earth=earth)
    dlat_ds = u_n[:, 1] / (R_M + h)
    dlon_ds = u_n[:, 0] / ((R_N + h) * C_ne[:, 2, 1])     # C_n_e[2, 1] = cos(lat)
    dC_ne_ds = _dC_n_e_ds(C_ne, dlat_ds, dlon_ds)
    r1 = mv(C_ne, u_n)
    r2 = mv(dC_ne_ds, u_n) + mv(C_ne, pt.du_ds_n)
    v, a = truth.v[:, None], truth.a[:, None]
    r_dot, r_ddot = v * r1, a * r1 + v * v * r2
    omega_e = np.array([0.0, 0.0, earth.omega_radps])
    f_e = r_ddot + 2.0 * np.cross(omega_e, r_dot) - mv(C_ne, g_n(lat, h, earth=earth))

    if attitude_rates is None:              # the track's: dA/ds, dϑ/ds (per metre)
        C_bn, dC_bn_ds = _attitude_matrices(
            truth, np.column_stack([pt.curvature_1pm, pt.elevation_rate]))
        dC_be_dt = v[:, :, None] * (dC_ne_ds @ C_bn + C_ne @ dC_bn_ds)
    else:
        C_bn, dC_bn_dt = _attitude_matrices(truth, np.asarray(attitude_rates, dtype=float))
        dC_be_dt = v[:, :, None] * (dC_ne_ds @ C_bn) + C_ne @ dC_bn_dt
    C_be = C_ne @ C_bn
    W = np.swapaxes(C_be, -1, -2) @ dC_be_dt
    omega_eb_b = 0.5 * np.stack([W[:, 2, 1] - W[:, 1, 2], W[:, 0, 2] - W[:, 2, 0],
                                 W[:, 1, 0] - W[:, 0, 1]], axis=-1)
    C_eb = np.swapaxes(C_be, -1, -2)
    return Imu(time_s=truth.time_s.copy(), f_b=mv(C_eb, f_e),
               omega_ib_b=mv(C_eb, omega_e) + omega_eb_b)
