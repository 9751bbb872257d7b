"""IMU error models and grade presets.

Each sensor triad (accelerometers, gyros) reads ::

    y_k = (I + S + M) x_k + b + b_GM(t_k) + w_k

* ``S = diag(s)``: scale-factor errors, ``s ~ N(0, σ_sf²)`` per axis, drawn once per run;
* ``M``: misalignment / non-orthogonality, the 6 off-diagonal elements ``~ N(0, σ_m²)``
  (rad), drawn once per run;
* ``b ~ N(0, σ_b²)``: constant (turn-on) bias per axis, drawn once per run;
* ``b_GM``: bias instability as a first-order Gauss–Markov process with stationary
  standard deviation ``σ_GM`` and correlation time ``τ``, sampled exactly:
  ``b_{k+1} = e^{−dt/τ} b_k + σ_GM sqrt(1 − e^{−2dt/τ}) n_k``, started stationary;
* ``w_k``: white noise of (two-sided) power spectral density ``N²`` — the "noise
  density" ``N`` in (m/s²)/√Hz = m/s/√s (velocity random walk) or (rad/s)/√Hz = rad/√s
  (angle random walk). The samples are *instantaneous* values of a white process seen
  through the sample-and-hold of the integrator, so each sample has
  ``σ_sample = N · sqrt(rate_hz)``: the integral of the noise over one interval then has
  variance ``N² dt``, as for the continuous intensity ``q = N²`` (the 2017 paper's
  ``(1e-5 m/s²)²·s`` is ``N = 1e-5``). The Allan deviation of the samples is ``N/√τ``.

Presets (`IMU_GRADES`, 1σ values; datasheet units converted once here):

=========== ========================= ========================= ===========================
preset      gyro                      accelerometer             source / reasoning
=========== ========================= ========================= ===========================
perfect     none                      none                      error-free reference
paper2017   N = 1e-6 rad/s/√Hz         N = 1e-5 m/s²/√Hz          paper's accel intensity; gyro
                                                                 chosen so g·(gyro-driven tilt)
                                                                 matches accel noise (N_a/g)
navigation  ARW 0.002 °/√h, b 0.005 °/h, VRW 10 µg/√Hz, b 30 µg,  navigation grade (ring-laser /
            GM 0.003 °/h τ 3600 s,     GM 10 µg τ 3600 s,        FOG class; Groves 2013
            SF 5 ppm, mis 10 µrad      SF 50 ppm, mis 10 µrad    Table 4.1 ranges)
tactical    ARW 0.1 °/√h, b 1 °/h,     VRW 50 µg/√Hz, b 0.5 mg,  tactical grade FOG/MEMS
            GM 0.5 °/h τ 600 s,        GM 50 µg τ 600 s,
            SF 100 ppm, mis 0.2 mrad   SF 300 ppm, mis 0.2 mrad
mems        ARW 0.3 °/√h, b 10 °/h,    VRW 150 µg/√Hz, b 3 mg,   industrial MEMS after a
            GM 5 °/h τ 300 s,          GM 0.05 mg τ 300 s,       static calibration
            SF 1000 ppm, mis 1 mrad    SF 1000 ppm, mis 1 mrad   (ADIS1646x-class datasheets)
=========== ========================= ========================= ===========================

(``g`` here is standard gravity 9.80665 m/s² for the µg/mg units.)
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import numpy.typing as npt

from strapdown.errors import StrapdownError

if TYPE_CHECKING:
    from strapdown.imu import Imu

__all__ = ["ImuErrors", "TriadErrors", "IMU_GRADES", "imu_grade", "apply_imu_errors",
           "gauss_markov_recursion", "rows_times", "STANDARD_GRAVITY_MPS2"]

Array = npt.NDArray[np.float64]

#: Standard gravity, m/s² (the unit "g" of datasheets, not a local gravity value).
STANDARD_GRAVITY_MPS2 = 9.80665
_DEG = math.pi / 180.0
_HOUR_S = 3600.0
_MICRO_G = 1e-6 * STANDARD_GRAVITY_MPS2
_PPM = 1e-6
#: deg/√h -> rad/√s (angle random walk)
_DEG_RTHR = _DEG / math.sqrt(_HOUR_S)
#: deg/h -> rad/s
_DEG_HR = _DEG / _HOUR_S


@dataclass(frozen=True)
class ImuErrors:
    """IMU error parameters (1σ values; see the module docstring for the model).

    Parameters
    ----------
    accel_noise_density_mps2_rthz, gyro_noise_density_radps_rthz : float
        White-noise density N: (m/s²)/√Hz and (rad/s)/√Hz.
    accel_bias_mps2, gyro_bias_radps : float
        σ of the constant per-run bias: m/s², rad/s.
    accel_bias_instability_mps2, gyro_bias_instability_radps : float
        Stationary σ of the Gauss–Markov bias: m/s², rad/s.
    accel_bias_tau_s, gyro_bias_tau_s : float
        Correlation times of the Gauss–Markov biases, s (> 0).
    accel_scale_factor_ppm, gyro_scale_factor_ppm : float
        σ of the scale-factor errors, parts per million.
    accel_misalignment_rad, gyro_misalignment_rad : float
        σ of each off-diagonal misalignment element, rad.
    name : str
        Preset name or ``"custom"``.
    """

    accel_noise_density_mps2_rthz: float = 0.0
    gyro_noise_density_radps_rthz: float = 0.0
    accel_bias_mps2: float = 0.0
    gyro_bias_radps: float = 0.0
    accel_bias_instability_mps2: float = 0.0
    gyro_bias_instability_radps: float = 0.0
    accel_bias_tau_s: float = 3600.0
    gyro_bias_tau_s: float = 3600.0
    accel_scale_factor_ppm: float = 0.0
    gyro_scale_factor_ppm: float = 0.0
    accel_misalignment_rad: float = 0.0
    gyro_misalignment_rad: float = 0.0
    name: str = "custom"

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name == "name":
                continue
            value = getattr(self, f.name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise StrapdownError(f"{f.name} must be a finite number >= 0, got {value!r}")
        if self.accel_bias_tau_s <= 0 or self.gyro_bias_tau_s <= 0:
            raise StrapdownError("bias correlation times must be > 0 s")

    @property
    def is_perfect(self) -> bool:
        """True when every error is zero."""
        return all(getattr(self, f.name) == 0 for f in fields(self)
                   if f.name not in ("name", "accel_bias_tau_s", "gyro_bias_tau_s"))

    def triad(self, sensor: str) -> "TriadErrors":
        """The parameters of one triad, ``"accel"`` (m/s² units) or ``"gyro"`` (rad/s)."""
        unit = {"accel": "mps2", "gyro": "radps"}[sensor]
        get = lambda name: getattr(self, f"{sensor}_{name}")  # noqa: E731
        return TriadErrors(noise_density=get(f"noise_density_{unit}_rthz"),
                           bias=get(f"bias_{unit}"), instability=get(f"bias_instability_{unit}"),
                           tau_s=get("bias_tau_s"), scale_factor_ppm=get("scale_factor_ppm"),
                           misalignment_rad=get("misalignment_rad"))


class TriadErrors(NamedTuple):
    """One triad's error parameters in its own units (m/s² or rad/s), 1σ."""

    noise_density: float
    bias: float
    instability: float
    tau_s: float
    scale_factor_ppm: float
    misalignment_rad: float


IMU_GRADES: dict[str, ImuErrors] = {
    "perfect": ImuErrors(name="perfect"),
    "paper2017": ImuErrors(accel_noise_density_mps2_rthz=1e-5,
                           gyro_noise_density_radps_rthz=1e-6, name="paper2017"),
    "navigation": ImuErrors(
        gyro_noise_density_radps_rthz=0.002 * _DEG_RTHR, gyro_bias_radps=0.005 * _DEG_HR,
        gyro_bias_instability_radps=0.003 * _DEG_HR, gyro_bias_tau_s=3600.0,
        gyro_scale_factor_ppm=5.0, gyro_misalignment_rad=10e-6,
        accel_noise_density_mps2_rthz=10 * _MICRO_G, accel_bias_mps2=30 * _MICRO_G,
        accel_bias_instability_mps2=10 * _MICRO_G, accel_bias_tau_s=3600.0,
        accel_scale_factor_ppm=50.0, accel_misalignment_rad=10e-6, name="navigation"),
    "tactical": ImuErrors(
        gyro_noise_density_radps_rthz=0.1 * _DEG_RTHR, gyro_bias_radps=1.0 * _DEG_HR,
        gyro_bias_instability_radps=0.5 * _DEG_HR, gyro_bias_tau_s=600.0,
        gyro_scale_factor_ppm=100.0, gyro_misalignment_rad=0.2e-3,
        accel_noise_density_mps2_rthz=50 * _MICRO_G, accel_bias_mps2=500 * _MICRO_G,
        accel_bias_instability_mps2=50 * _MICRO_G, accel_bias_tau_s=600.0,
        accel_scale_factor_ppm=300.0, accel_misalignment_rad=0.2e-3, name="tactical"),
    "mems": ImuErrors(
        gyro_noise_density_radps_rthz=0.3 * _DEG_RTHR, gyro_bias_radps=10.0 * _DEG_HR,
        gyro_bias_instability_radps=5.0 * _DEG_HR, gyro_bias_tau_s=300.0,
        gyro_scale_factor_ppm=1000.0, gyro_misalignment_rad=1e-3,
        accel_noise_density_mps2_rthz=150 * _MICRO_G, accel_bias_mps2=3000 * _MICRO_G,
        accel_bias_instability_mps2=50 * _MICRO_G, accel_bias_tau_s=300.0,
        accel_scale_factor_ppm=1000.0, accel_misalignment_rad=1e-3, name="mems"),
}


def imu_grade(grade: str | ImuErrors) -> ImuErrors:
    """The `ImuErrors` of a preset name (or the argument itself).

    Raises
    ------
    StrapdownError
        For an unknown preset name.
    """
    if isinstance(grade, ImuErrors):
        return grade
    try:
        return IMU_GRADES[grade]
    except KeyError:
        raise StrapdownError(f"unknown IMU grade {grade!r}; presets are "
                             f"{', '.join(IMU_GRADES)}") from None


def _gauss_markov(n: int, dt: float, sigma: float, tau_s: float,
                  rng: np.random.Generator) -> Array:
    """(n, 3) stationary first-order Gauss–Markov samples (exact discretization).

    The draws are made for any `sigma`, so that the draws after them do not depend on it;
    with ``sigma = 0`` the samples are zeros (what the recursion gives) without the filter.
    """
    phi = math.exp(-dt / tau_s)
    start = sigma * rng.standard_normal(3)
    drive = rng.standard_normal((n, 3))
    if sigma == 0.0:
        return np.zeros((n, 3))
    gain = sigma * math.sqrt(-math.expm1(-2.0 * dt / tau_s))
    return gauss_markov_recursion(drive, gain=gain, phi=phi, start=start)


def gauss_markov_recursion(drive: Array, *, gain: float, phi: float, start: Array) -> Array:
    """``y_k = φ y_{k−1} + g w_k`` down the columns of `drive`, from ``y_{−1} = start``.

    The same numbers, to the bit, as ``scipy.signal.lfilter([g], [1, −φ], drive, axis=0,
    zi=φ·start)`` (its direct form: ``y_k = z + g w_k``, ``z = φ y_k``), computed by a
    plain loop over Python floats (~0.2 µs a sample) so that no run imports
    ``scipy.signal`` (~0.3 s and ~40 MB: it loads ``scipy.stats``).

    Parameters
    ----------
    drive : ndarray, shape (n, k)
        Driving noise.
    gain, phi : float
        ``g`` and ``φ``.
    start : ndarray, shape (k,)
        The state before the first sample.

    Returns
    -------
    ndarray, shape (n, k)
    """
    x = gain * drive
    out = np.empty_like(x)
    for j in range(x.shape[1]):
        y, column = float(start[j]), []
        append = column.append
        for value in x[:, j].tolist():
            y = phi * y + value
            append(y)
        out[:, j] = column
    return out


#: Rows per block of `rows_times`.
_PRODUCT_BLOCK_ROWS = 8192


def rows_times(rows: Array, matrix: Array) -> Array:
    """``rows @ matrix.T`` (each row times `matrix`), computed in blocks of
    `_PRODUCT_BLOCK_ROWS` rows.

    The same numbers to the bit as the whole product (each row goes through the same BLAS
    kernel; `tests/strapdown/test_imu_errors.py`), but a block is too small for OpenBLAS to
    split over threads: a (100 000, 3) product split over two threads took 40-80 ms of
    wall time (0.4 ms alone) whenever the second core was busy, e.g. with the plotting
    process of ``railnav run`` (`railnav.jobs.plot_worker`).

    Parameters
    ----------
    rows : ndarray, shape (N, k)
    matrix : ndarray, shape (m, k)

    Returns
    -------
    ndarray, shape (N, m)
    """
    rows = np.asarray(rows, dtype=float)
    out = np.empty((rows.shape[0], matrix.shape[0]))
    for start in range(0, rows.shape[0], _PRODUCT_BLOCK_ROWS):
        block = slice(start, start + _PRODUCT_BLOCK_ROWS)
        out[block] = rows[block] @ matrix.T
    return out


def _corrupt_triad(true: Array, dt: float, p: TriadErrors,
                   rng: np.random.Generator) -> Array:
    """One triad's measurements (N, 3) from true values (N, 3); draw order is fixed."""
    scale = p.scale_factor_ppm * _PPM * rng.standard_normal(3)
    mis = p.misalignment_rad * rng.standard_normal((3, 3))
    matrix = np.eye(3) + np.diag(scale) + (mis - np.diag(np.diag(mis)))
    bias = p.bias * rng.standard_normal(3)
    drift = _gauss_markov(len(true), dt, p.instability, p.tau_s, rng)
    noise = p.noise_density / math.sqrt(dt) * rng.standard_normal(true.shape)
    return rows_times(true, matrix) + bias + drift + noise


def apply_imu_errors(imu: Imu, errors: str | ImuErrors, rng: np.random.Generator) -> Imu:
    """The measured IMU: the true record with the errors of `errors` drawn from `rng`.

    Parameters
    ----------
    imu : Imu
        Error-free samples (uniform interval ``dt``).
    errors : str or ImuErrors
        A preset name from `IMU_GRADES` or explicit parameters.
    rng : numpy.random.Generator
        Source of every random draw (accelerometers first, then gyros).

    Returns
    -------
    Imu
        Same times; `imu` itself when the errors are all zero.
    """
    errors = imu_grade(errors)
    if errors.is_perfect or len(imu.time_s) < 2:
        return imu
    dt = imu.dt
    f_b = _corrupt_triad(imu.f_b, dt, errors.triad("accel"), rng)
    omega = _corrupt_triad(imu.omega_ib_b, dt, errors.triad("gyro"), rng)
    return replace(imu, f_b=f_b, omega_ib_b=omega)
