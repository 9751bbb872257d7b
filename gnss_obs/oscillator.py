"""Receiver clock model: bias and drift driven by white and random-walk frequency noise.

State ``[b, d]``: clock bias ``b = c δt_r`` (m) and drift ``d = c dδt_r/dt`` (m/s), with
``db/dt = d + w_b`` and ``dd/dt = w_d``; ``w_b`` and ``w_d`` are white with power spectral
densities ``q_bias_m2ps`` (m²/s) and ``q_drift_m2ps3`` (m²/s³). From the power-law
coefficients of the oscillator's fractional-frequency spectrum (``h0`` white FM, in s;
``h_-2`` random-walk FM, in 1/s): ``q_b = c² h0 / 2`` and ``q_d = 2π² c² h_-2``
(Brown & Hwang, *Introduction to Random Signals and Applied Kalman Filtering*, 4th ed.,
§9.3, whose Table 9.2 gives the presets below). The exact discrete process noise over a
step ``Δt`` is

``Q = [[q_b Δt + q_d Δt³/3, q_d Δt²/2], [q_d Δt²/2, q_d Δt]]``,

which `process_noise` returns (for a filter) and `simulate_clock` samples (for the truth).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from gnss_obs.constants import SPEED_OF_LIGHT_MPS
from gnss_obs.errors import GnssError

__all__ = ["Oscillator", "OSCILLATORS", "oscillator_from_name", "process_noise",
           "simulate_clock"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Oscillator:
    """Receiver oscillator noise (module docstring).

    Parameters
    ----------
    q_bias_m2ps : float
        PSD of the white noise on the bias rate, m²/s (white frequency noise).
    q_drift_m2ps3 : float
        PSD of the white noise on the drift rate, m²/s³ (random-walk frequency noise).
    """

    q_bias_m2ps: float
    q_drift_m2ps3: float

    def __post_init__(self) -> None:
        for name in ("q_bias_m2ps", "q_drift_m2ps3"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise GnssError(f"{name} must be a finite number >= 0, got {v!r}")

    @classmethod
    def from_allan(cls, *, h0_s: float, h_minus2_per_s: float) -> "Oscillator":
        """From power-law coefficients h0 (s) and h_-2 (1/s) of the frequency spectrum."""
        c2 = SPEED_OF_LIGHT_MPS ** 2
        return cls(q_bias_m2ps=c2 * h0_s / 2.0,
                   q_drift_m2ps3=c2 * 2.0 * np.pi ** 2 * h_minus2_per_s)


#: Presets: Brown & Hwang Table 9.2 (temperature-compensated and oven-controlled crystals),
#: and a noiseless clock.
OSCILLATORS: dict[str, Oscillator] = {
    "tcxo": Oscillator.from_allan(h0_s=2e-19, h_minus2_per_s=2e-20),
    "ocxo": Oscillator.from_allan(h0_s=8e-20, h_minus2_per_s=4e-23),
    "perfect": Oscillator(0.0, 0.0),
}


def oscillator_from_name(name: str) -> Oscillator:
    """A preset by name (``tcxo``, ``ocxo``, ``perfect``)."""
    try:
        return OSCILLATORS[name]
    except KeyError:
        raise GnssError(f"unknown oscillator {name!r}; expected one of "
                        f"{sorted(OSCILLATORS)}") from None


def process_noise(oscillator: Oscillator, dt: npt.ArrayLike) -> Array:
    """Discrete process-noise covariance of ``[b, d]`` over steps `dt`.

    Parameters
    ----------
    oscillator : Oscillator
    dt : array_like, shape (...)
        Step lengths, s.

    Returns
    -------
    ndarray, shape (..., 2, 2)
        Covariance, [[m², m²/s], [m²/s, m²/s²]].
    """
    dt = np.asarray(dt, dtype=float)
    qb, qd = oscillator.q_bias_m2ps, oscillator.q_drift_m2ps3
    Q = np.empty(dt.shape + (2, 2))
    Q[..., 0, 0] = qb * dt + qd * dt ** 3 / 3.0
    Q[..., 0, 1] = Q[..., 1, 0] = qd * dt ** 2 / 2.0
    Q[..., 1, 1] = qd * dt
    return Q


def simulate_clock(gps_time_s: npt.ArrayLike, oscillator: Oscillator, *, bias0_m: float,
                   drift0_mps: float, rng: np.random.Generator) -> tuple[Array, Array]:
    """A realisation of the receiver clock at the given times.

    Parameters
    ----------
    gps_time_s : array_like, shape (N,)
        Increasing times, s.
    oscillator : Oscillator
    bias0_m, drift0_mps : float
        Clock bias (m) and drift (m/s) at the first time.
    rng : numpy.random.Generator

    Returns
    -------
    bias_m, drift_mps : ndarray, shape (N,)
    """
    t = np.asarray(gps_time_s, dtype=float)
    n = t.size
    bias, drift = np.empty(n), np.empty(n)
    if n == 0:
        return bias, drift
    dt = np.diff(t)
    Q = process_noise(oscillator, dt)
    # Cholesky of each 2x2 Q (zero-safe): L = [[l00, 0], [l10, l11]].
    l00 = np.sqrt(Q[:, 0, 0])
    l10 = np.divide(Q[:, 1, 0], l00, out=np.zeros_like(l00), where=l00 > 0)
    l11 = np.sqrt(np.maximum(Q[:, 1, 1] - l10 ** 2, 0.0))
    z = rng.standard_normal((n - 1, 2))
    w_b = l00 * z[:, 0]
    w_d = l10 * z[:, 0] + l11 * z[:, 1]
    bias[0], drift[0] = bias0_m, drift0_mps
    for k in range(n - 1):
        bias[k + 1] = bias[k] + drift[k] * dt[k] + w_b[k]
        drift[k + 1] = drift[k] + w_d[k]
    return bias, drift
