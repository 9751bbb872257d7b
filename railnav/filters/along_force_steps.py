r"""The accelerometer biases' steps from the along-track specific force, as an envelope.

The IMU error model, and the curves' kinematic steps of the same biases:
`railnav.filters.scale_noise`.

**The along-track specific force** ``a`` (traction and braking, ≲ 1 m/s², and the
grade's share of gravity, ``g sin ϑ``: 0.1 m/s² per 1 % of grade) steps the effective
bias too: by ``S_xx Δa`` on the x axis and ``M_yx Δa``, ``M_zx Δa`` on y and z, variances
``σ_sf² Δa²`` and ``σ_m² Δa²``. Unlike a curve's input it does not start from 0, it comes
back (a braking, a stop, a start) and, for the tactical grade, the step competes with the
bias's *posterior* σ, not its instability: ``σ_m · 1 m/s²`` is 0.2 mm/s², and the
normal row ties ``b_az`` to 0.15 mm/s², where it reads the step as a pitch of ``M_zx``
(outage_20min, seed 5: braking onset, `docs/consistency-ablations.md`, stops 26–28).

`AlongForceSteps` gives it as an envelope, for every grade with accelerometer scale factors
or misalignments (the gate this replaced compared ``σ · 1 m/s²`` with the bias
instability and left it to MEMS). The bias's error has a part ``k (a − a_ref)`` with ``k``
the column's element (a constant of the run) and ``a_ref`` where the information tied the
bias; an update with gain ``K`` (``kept = 1 − K`` = the bias variance after over before)
leaves ``a − a_ref`` times ``kept``, so ``a_ref ← kept a_ref + (1 − kept) a_tie``, and
the part of the bias variance that stands for it, ``held``, times ``kept²``. Each chunk
gives ``max(σ² (a − a_ref)² − held, 0)`` and adds it to ``held``: the filter's variance
always covers ``σ² (a − a_ref)²`` (exactly, for a scalar filter, from the largest
excursion since the last tie on; `tests/railnav/filters/test_along_force_steps.py` checks
both against a Monte Carlo). ``a`` is the body-x specific force through a low-pass filter
of 0.5 s (`smoothed_along_force`, closed form on the samples' piecewise-linear
interpolation), at every sample; the envelope is a running maximum over the samples and
each sample's increment is the density of its step, so a cut of the record moves no
variance. Ties happen only at chunk starts that follow an epoch's update, a cut every
cutting shares (the filter's ``kept`` is read from P there, over the variance at the
previous tie plus the process noise given since: the continuous rows' information of an
outage is accounted at its first epoch, tied at that epoch's force). Streaming, jittered
logs and network cycles then give the same variances. It is conservative where the truth
returns: after a braking and a stop, ``held`` keeps the braking's variance until
information ties the bias again (a random walk of ``Σ|Δ(a²)|`` over chunk means, tried in
stop 26, gave variance at every change and back again, 20 % more with a jittered log's
extra cuts, and nothing for a change of sign: ``Δ(a²) = 0`` from −0.5 to +0.5 m/s²).
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from strapdown.imu_errors import ImuErrors

__all__ = ["AlongForceSteps", "smoothed_along_force", "ALONG_SMOOTHING_S"]

Array = npt.NDArray[np.float64]


class AlongForceSteps:
    """The accelerometer biases' step from the along-track specific force, as the
    shortfall of an envelope (module docstring): the variance ``σ_i² (a − a_ref,i)²`` of
    the step since each bias was last tied, less what was given and is still held.

    Parameters
    ----------
    imu : ImuErrors
        The grade the filter assumes (its accelerometer scale-factor and misalignment σ).

    Attributes
    ----------
    coefficients : ndarray, shape (3,)
        ``[σ_sf², σ_m², σ_m²]``, the variance per (m/s²)² of the x, y, z biases' step.
    reference_mps2 : ndarray, shape (3,) or None
        Where each bias was last tied, ``a_ref``, m/s² (None before the first chunk).
    held : ndarray, shape (3,)
        The step variance given and not yet consumed by information, (m/s²)².
    """

    def __init__(self, imu: ImuErrors) -> None:
        sf, m = imu.accel_scale_factor_ppm * 1e-6, imu.accel_misalignment_rad
        self.coefficients = np.array([sf * sf, m * m, m * m])
        self.reference_mps2: Array | None = None
        self.held = np.zeros(3)
        self._last_mps2 = 0.0
        self._start: Array | None = None       # the biases' variances at the last tie
        self._given = np.zeros(3)              # the process noise given since

    @classmethod
    def for_grade(cls, imu: ImuErrors) -> "AlongForceSteps | None":
        """An envelope for `imu`; None when its accelerometers have no scale factor or
        misalignment (nothing to give: the paper2017 grade)."""
        return None if imu.accel_scale_factor_ppm == imu.accel_misalignment_rad == 0.0 \
            else cls(imu)

    def chunk_variances(self, along_mps2: Array, bias_variances: Array, *, tie: bool
                        ) -> Array:
        """`variances` of a filter's chunk, ``kept`` from its biases' variances.

        Parameters
        ----------
        along_mps2 : ndarray, shape (M,)
            As for `variances`.
        bias_variances : ndarray, shape (3,)
            The accelerometer biases' variances at the chunk's start (the prior), (m/s²)².
        tie : bool
            Whether an epoch's update came since the previous call (the chunk starts at an
            epoch, a cut every cutting of the record shares): ``kept`` is then
            `bias_variances` over those at the previous tie plus the process noise given
            since (`noise_given`); else 1, and the information since waits for the next
            epoch (module docstring).
        """
        now = np.asarray(bias_variances, dtype=float).copy()
        if self._start is None or tie:
            kept = np.ones(3) if self._start is None else \
                now / np.maximum(self._start + self._given, np.finfo(float).tiny)
            self._start, self._given = now, np.zeros(3)
        else:
            kept = np.ones(3)
        return self.variances(along_mps2, kept=kept)

    def noise_given(self, noise: Array) -> None:
        """Add the process noise the chunk of the latest `chunk_variances` gave the
        accelerometer biases, (m/s²)², shape (3,) (their densities, this envelope's
        included, times the steps)."""
        self._given = self._given + np.asarray(noise, dtype=float)

    def variances(self, along_mps2, *, kept: Array) -> Array:
        """The step variances to give over a chunk's samples, ``[x, y, z]``, (m/s²)².

        Parameters
        ----------
        along_mps2 : float or ndarray, shape (M,)
            The along-track specific force at each sample (`smoothed_along_force`), m/s²;
            the last is where the information until the next tie (the epoch's update at
            the chunk's end) ties the biases.
        kept : ndarray, shape (3,)
            Each bias's variance now over what it would be without the information since
            the previous call (its variance then plus the process noise given since),
            clipped to [0, 1]: 1 without information, 0 when it tied the bias exactly;
            ``1 − K`` of a scalar Kalman update. That information tied the bias at the
            previous call's force.

        Returns
        -------
        ndarray, shape (M, 3), or (3,) for a float
            Each sample's increment of ``max(held_i, σ_i² (a − a_ref,i)²)`` over the
            samples (its running maximum), the first from ``held`` after the tie; the
            first call ties ``a_ref`` at the first sample.
        """
        along = np.atleast_1d(np.asarray(along_mps2, dtype=float))
        if self.reference_mps2 is None:                 # tied at the first sample
            self.reference_mps2, self._last_mps2 = np.full(3, along[0]), float(along[0])
        kept = np.clip(np.asarray(kept, dtype=float), 0.0, 1.0)
        self.reference_mps2 = kept * self.reference_mps2 + (1.0 - kept) * self._last_mps2
        target = self.coefficients * (along[:, None] - self.reference_mps2) ** 2
        running = np.maximum.accumulate(np.vstack([kept * kept * self.held, target]), axis=0)
        self.held, self._last_mps2 = running[-1], float(along[-1])
        added = np.diff(running, axis=0)
        return added if np.ndim(along_mps2) else added[0]


#: Time constant of the along-track specific force's smoothing (`smoothed_along_force`), s.
ALONG_SMOOTHING_S = 0.5
#: Chunk spans (in time constants) below which `smoothed_along_force` scales a cumulative
#: sum instead of stepping sample by sample.
_SCALED_SPAN = 200.0


def smoothed_along_force(t_s: Array, f_mps2: Array, last: tuple[float, float, float] | None,
                         *, time_constant_s: float = ALONG_SMOOTHING_S
                         ) -> tuple[float, tuple[float, float, float]]:
    """The body-x specific force through a first-order low-pass filter, at the last sample.

    The filter runs on the samples' piecewise-linear interpolation, in closed form per
    step, so its value at a time does not depend on how the samples are cut into chunks,
    nor (to the interpolation's error) on jitter and dropped samples (module docstring).

    Parameters
    ----------
    t_s : ndarray, shape (M,)
        Sample times, s (increasing, after ``last``'s).
    f_mps2 : ndarray, shape (M,)
        The samples' specific force along body x, m/s².
    last : (float, float, float) or None
        ``(t, f, y)`` of the previous call's last sample: its time, input and output;
        None: start at the first sample's value.
    time_constant_s : float

    Returns
    -------
    y : ndarray, shape (M,)
        The output at each sample, m/s².
    last : (float, float, float)
        ``(t, f, y)`` at ``t_s[-1]`` for the next call.
    """
    t, f = np.asarray(t_s, dtype=float), np.asarray(f_mps2, dtype=float)
    if last is None:
        last = (float(t[0]), float(f[0]), float(f[0]))
    tt, ff = np.concatenate([[last[0]], t]), np.concatenate([[last[1]], f])
    h = np.maximum(np.diff(tt), 0.0)
    decay = np.exp(-h / time_constant_s)
    with np.errstate(divide="ignore", invalid="ignore"):
        ramp = np.where(h > 0.0, -np.expm1(-h / time_constant_s) * time_constant_s / h, 1.0)
    # y(t + h) = e y(t) + f₁ − e f₀ − (f₁ − f₀)(τ/h)(1 − e), a linear input f₀ → f₁
    drive = ff[1:] - decay * ff[:-1] - (ff[1:] - ff[:-1]) * ramp
    if (tt[-1] - tt[0]) / time_constant_s < _SCALED_SPAN:
        scale = np.exp((tt[1:] - tt[-1]) / time_constant_s)     # ≤ 1, no overflow
        y = (np.exp((tt[0] - tt[-1]) / time_constant_s) * last[2]
             + np.cumsum(scale * drive)) / scale
    else:                                                       # a long gap: step by step
        y, prev = np.empty(t.size), last[2]
        for k in range(t.size):
            prev = y[k] = decay[k] * prev + drive[k]
    return y, (float(t[-1]), float(f[-1]), float(y[-1]))
