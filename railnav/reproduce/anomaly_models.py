"""The two linear channels of Ivanov et al. 2021 (SEEDS.md §2): parameters and matrices.

Ivanov, Shishkin, Boikov, Ivanov, Lezhneva, "Adaptive algorithms of information processing
in navigation complexes of mobile ground objects", J. Communications Technology and
Electronics, 2021 (summarized in ``docs/papers-and-errata.md`` §2). Frame of the
paper: ``x`` north, ``y`` east, ``H`` up (relative height); SI units throughout.

Horizontal channel (paper eqs. 8–11, 14, 15), state ``[x, y, V_x, V_y, Δa_x, Δa_y]``::

    x_{k+1}  = x_k + T V_k + ½T² (a^INS_k − Δa_k) − ½T² σ_n n_k
    V_{k+1}  = V_k + T (a^INS_k − Δa_k) − T σ_n n_k,     Δa_{k+1} = Δa_k
    z        = [x, y] + σ_xy n  (GNSS),   [V_x, V_y] + σ_V n  (speed sensor)

Vertical channel (eqs. 12, 13, 16, 17), state ``[H, V_z, ΔH, Δa_z]``, control ``[a_z^INS, g]``;
barometer ``ξ1 = H + ΔH + u`` with first-order Gauss–Markov noise
``u_{k+1} = φ u_k + σ_b (1 − φ²)^½ n``, ``φ = e^{−γ_b T}`` (eq. 4); GNSS
``ξ2 = H + R0 + σ_z n`` (eq. 6). ``σ_n = σ_a (2T/α_a)^½`` is the per-sample white noise of
the accelerometers (eq. 1).

Measurement differencing (eqs. 23–24): ``y = [ξ1(k+1) − φ ξ1(k), ξ2(k+1)]`` is a function of
``x_k``: ``y = Φ_yx x_k + c + v`` with ``Φ_yx = [H1 Φ − φ H1; H2 Φ]``,
``c = [H1 Ψ W; H2 Ψ W + R0]`` and ``v = [H1 w + σ_b(1−φ²)^½ n_u; H2 w + σ_z n_z]``, so
``E[w vᵀ] = B_xy = [Q H1ᵀ, Q H2ᵀ]`` and ``E[v vᵀ] = B_yy``. :func:`ekf.correlated_step` runs
this form exactly (no approximation).

Errata of the paper (not copied):

* eq. 24: ``[B_yy⁻¹ + Φ_yx P Φ_yxᵀ]⁻¹`` must be ``[B_yy + Φ_yx P Φ_yxᵀ]⁻¹``; the covariance
  update lacks the process noise ``+ Γ Γᵀ``; ``B_yy[0, 0] = H1 Γ Γᵀ H1ᵀ − φ²`` must be
  ``H1 Γ Γᵀ H1ᵀ + σ_b² (1 − φ²)`` (as written it is negative).
* eq. 22: the innovation covariance ``H Φ P(k+1|k) Φᵀ Hᵀ + R`` propagates twice; the
  covariance of ``ε = Ξ − H(Φ x* + Ψ W)`` is ``H P(k+1|k) Hᵀ + R``. Likewise eq. 25 omits the
  process noise that eq. 30 includes; we use the exact ``S`` in both channels.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from railnav.errors import ConfigError

__all__ = ["AnomalyParams", "HORIZONTAL", "VERTICAL", "HorizontalChannel", "VerticalChannel",
           "horizontal_channel", "vertical_channel"]

Array = npt.NDArray[np.float64]

#: State of the horizontal channel (paper X_Γ): north/east position, velocity, accel bias.
HORIZONTAL = StateLayout.from_blocks([("pos", ("north", "east")),
                                      ("vel", ("v_north", "v_east")),
                                      ("accel_bias", ("bias_a_north", "bias_a_east"))])
#: State of the vertical channel (paper X_B): relative height, vertical speed, baro bias,
#: vertical accelerometer bias.
VERTICAL = StateLayout.from_blocks([("height", 1), ("v_up", 1), ("baro_bias", 1),
                                    ("bias_a_up", 1)])


@dataclass(frozen=True)
class AnomalyParams:
    """The paper's simulation parameters (§3.1, §3.2), SI units.

    Attributes
    ----------
    dt : float
        Sampling interval ``T`` of every sensor, s.
    gnss_height_offset_m : float
        ``R0``: the GNSS height is ``R0 + H`` (eq. 6), m.
    height_m : float
        True relative height ``H`` (constant), m.
    sigma_gnss_height_m, sigma_gnss_horizontal_m : float
        GNSS noise ``σ_z`` and ``σ_x = σ_y``, m.
    baro_bias_m : float
        True constant barometric error ``ΔH``, m.
    baro_noise_rate_per_s : float
        ``γ_BV`` of the Gauss–Markov baro noise, 1/s.
    sigma_baro_m : float
        Its standard deviation ``σ_BV``, m.
    accel_noise_rate_per_s : float
        ``α_a``, 1/s.
    sigma_accel_mps2 : float
        ``σ_a``, m/s².
    accel_bias_mps2 : float
        True constant accelerometer bias ``Δa`` on every axis, m/s².
    sigma_speed_mps : float
        Speed-sensor noise ``σ_V`` per axis, m/s.
    velocity_mps : float
        True ``V_x = V_y`` (constant), m/s.
    P0_horizontal : tuple of 6 float
        Initial variances of ``HORIZONTAL`` (m², m², m²/s², m²/s², m²/s⁴, m²/s⁴).
    P0_vertical : tuple of 4 float
        Initial variances of ``VERTICAL`` (m², m²/s², m², m²/s⁴).
    """

    dt: float = 0.02
    gnss_height_offset_m: float = 6_371_110.0
    height_m: float = 1000.0
    sigma_gnss_height_m: float = 7.0
    sigma_gnss_horizontal_m: float = 5.0
    baro_bias_m: float = 7.0
    baro_noise_rate_per_s: float = 10.0
    sigma_baro_m: float = 1.0
    accel_noise_rate_per_s: float = 50.0
    sigma_accel_mps2: float = 0.03
    accel_bias_mps2: float = 0.2
    sigma_speed_mps: float = 2.0
    velocity_mps: float = 8.0
    P0_horizontal: tuple[float, ...] = (300.0, 300.0, 20.0, 20.0, 0.01, 0.01)
    P0_vertical: tuple[float, ...] = (300.0, 20.0, 625.0, 0.01)

    def __post_init__(self) -> None:
        positive = ("dt", "sigma_gnss_height_m", "sigma_gnss_horizontal_m",
                    "baro_noise_rate_per_s", "sigma_baro_m", "accel_noise_rate_per_s",
                    "sigma_accel_mps2", "sigma_speed_mps")
        for f in fields(self):
            value = getattr(self, f.name)
            values = value if isinstance(value, tuple) else (value,)
            if not all(np.isfinite(v) for v in values):
                raise ConfigError(f"AnomalyParams.{f.name} must be finite, got {value!r}")
            if f.name in positive and not value > 0.0:
                raise ConfigError(f"AnomalyParams.{f.name} must be > 0, got {value!r}")
        for name, layout in (("P0_horizontal", HORIZONTAL), ("P0_vertical", VERTICAL)):
            value = getattr(self, name)
            if len(value) != layout.size or min(value) <= 0.0:
                raise ConfigError(f"AnomalyParams.{name} needs {layout.size} variances > 0, "
                                  f"got {value!r}")

    @property
    def sigma_accel_sample_mps2(self) -> float:
        """``σ_a (2T/α_a)^½``: standard deviation of one accelerometer sample's noise."""
        return self.sigma_accel_mps2 * np.sqrt(2.0 * self.dt / self.accel_noise_rate_per_s)

    @property
    def baro_correlation(self) -> float:
        """``φ = exp(−γ_BV T)``: one-step correlation of the baro noise."""
        return float(np.exp(-self.baro_noise_rate_per_s * self.dt))

    @property
    def sigma_baro_drive_m(self) -> float:
        """``σ_BV (1 − φ²)^½``: standard deviation of the baro noise's driving term."""
        return self.sigma_baro_m * float(np.sqrt(1.0 - self.baro_correlation ** 2))


def _axis_block(dt: float, sigma_n: float) -> tuple[Array, Array, Array]:
    """Transition, control and noise of one axis ``[position, velocity, accel bias]``.

    Returns ``Phi (3, 3)``, ``psi (3,)`` (gain of the measured acceleration) and
    ``gamma (3,)`` (gain of the standard-normal accelerometer noise) — eqs. 8–13.
    """
    Phi = np.array([[1.0, dt, -0.5 * dt * dt], [0.0, 1.0, -dt], [0.0, 0.0, 1.0]])
    psi = np.array([0.5 * dt * dt, dt, 0.0])
    return Phi, psi, -sigma_n * psi


@dataclass(frozen=True, eq=False)
class HorizontalChannel:
    """Matrices of the horizontal channel (eqs. 14, 15).

    Attributes
    ----------
    Phi : ndarray, shape (6, 6)
    Psi : ndarray, shape (6, 2)
        Gain of the control ``W = [a_x^INS, a_y^INS]``, m/s².
    Gamma : ndarray, shape (6, 2)
        Gain of the standard-normal accelerometer noise; ``Q = Γ Γᵀ``.
    H_gnss, H_speed : ndarray, shape (2, 6)
    R_gnss, R_speed : ndarray, shape (2, 2)
    """

    Phi: Array
    Psi: Array
    Gamma: Array
    H_gnss: Array
    H_speed: Array
    R_gnss: Array
    R_speed: Array

    @property
    def Q(self) -> Array:
        """Process-noise covariance ``Γ Γᵀ``, shape (6, 6)."""
        return self.Gamma @ self.Gamma.T


@dataclass(frozen=True, eq=False)
class VerticalChannel:
    """Matrices of the vertical channel (eqs. 16, 17, 23, 24).

    Attributes
    ----------
    Phi : ndarray, shape (4, 4)
    Psi : ndarray, shape (4, 2)
        Gain of the control ``W = [a_z^INS, g]``, m/s².
    Gamma : ndarray, shape (4, 1)
    H_baro, H_gnss : ndarray, shape (1, 4)
    baro_correlation : float
        ``φ``.
    R_baro_drive, R_gnss : float
        ``σ_b²(1 − φ²)`` and ``σ_z²``, m².
    R_baro : float
        Stationary baro-noise variance ``σ_b²`` (first sample), m².
    gnss_offset_m : float
        ``R0``, m.
    """

    Phi: Array
    Psi: Array
    Gamma: Array
    H_baro: Array
    H_gnss: Array
    baro_correlation: float
    R_baro_drive: float
    R_gnss: float
    R_baro: float
    gnss_offset_m: float

    @property
    def Q(self) -> Array:
        """Process-noise covariance ``Γ Γᵀ``, shape (4, 4)."""
        return self.Gamma @ self.Gamma.T

    @property
    def Phi_yx(self) -> Array:
        """``[H1 Φ − φ H1; H2 Φ]``, shape (2, 4): the differenced measurements vs ``x_k``."""
        return np.vstack([self.H_baro @ self.Phi - self.baro_correlation * self.H_baro,
                          self.H_gnss @ self.Phi])

    @property
    def B_xy(self) -> Array:
        """``E[w vᵀ] = [Q H1ᵀ, Q H2ᵀ]``, shape (4, 2)."""
        return self.Q @ np.vstack([self.H_baro, self.H_gnss]).T

    @property
    def B_yy(self) -> Array:
        """``E[v vᵀ]``, shape (2, 2) (paper eq. 24, corrected)."""
        H = np.vstack([self.H_baro, self.H_gnss])
        return H @ self.Q @ H.T + np.diag([self.R_baro_drive, self.R_gnss])


def horizontal_channel(params: AnomalyParams) -> HorizontalChannel:
    """The horizontal channel's matrices for ``params``."""
    Phi3, psi3, gamma3 = _axis_block(params.dt, params.sigma_accel_sample_mps2)
    n = HORIZONTAL.size
    Phi, Psi, Gamma = np.zeros((n, n)), np.zeros((n, 2)), np.zeros((n, 2))
    for axis, (pos, vel, bias) in enumerate((("north", "v_north", "bias_a_north"),
                                             ("east", "v_east", "bias_a_east"))):
        idx = [HORIZONTAL.index(pos), HORIZONTAL.index(vel), HORIZONTAL.index(bias)]
        Phi[np.ix_(idx, idx)] = Phi3
        Psi[idx, axis] = psi3
        Gamma[idx, axis] = gamma3
    H_gnss, H_speed = np.zeros((2, n)), np.zeros((2, n))
    H_gnss[:, HORIZONTAL.slice("pos")] = np.eye(2)
    H_speed[:, HORIZONTAL.slice("vel")] = np.eye(2)
    return HorizontalChannel(Phi=Phi, Psi=Psi, Gamma=Gamma, H_gnss=H_gnss, H_speed=H_speed,
                             R_gnss=params.sigma_gnss_horizontal_m ** 2 * np.eye(2),
                             R_speed=params.sigma_speed_mps ** 2 * np.eye(2))


def vertical_channel(params: AnomalyParams) -> VerticalChannel:
    """The vertical channel's matrices for ``params``."""
    Phi3, psi3, gamma3 = _axis_block(params.dt, params.sigma_accel_sample_mps2)
    n = VERTICAL.size
    idx = [VERTICAL.index("height"), VERTICAL.index("v_up"), VERTICAL.index("bias_a_up")]
    Phi, Psi, Gamma = np.eye(n), np.zeros((n, 2)), np.zeros((n, 1))
    Phi[np.ix_(idx, idx)] = Phi3
    Psi[idx, 0], Psi[idx, 1] = psi3, -psi3          # W = [a_z^INS, g]: a − g
    Gamma[idx, 0] = gamma3
    H_baro, H_gnss = np.zeros((1, n)), np.zeros((1, n))
    H_baro[0, [VERTICAL.index("height"), VERTICAL.index("baro_bias")]] = 1.0
    H_gnss[0, VERTICAL.index("height")] = 1.0
    return VerticalChannel(Phi=Phi, Psi=Psi, Gamma=Gamma, H_baro=H_baro, H_gnss=H_gnss,
                           baro_correlation=params.baro_correlation,
                           R_baro_drive=params.sigma_baro_drive_m ** 2,
                           R_gnss=params.sigma_gnss_height_m ** 2,
                           R_baro=params.sigma_baro_m ** 2,
                           gnss_offset_m=params.gnss_height_offset_m)
