r"""The attitude error of sampling an angular rate that steps at a section joint.

Where a track's curvature steps (an arc entered without a transition: ``dA/ds`` jumps by
``Δκ``) or its grade rate steps (the ends of a vertical curve: ``dϑ/ds`` jumps by
``Δϑ'``), the vehicle's angular rate steps too: by ``v Δκ`` about the track normal (yaw)
and ``v Δϑ'`` about the lateral axis (pitch). The IMU samples are instantaneous values
(`strapdown.imu_errors`), and the step's integrator interpolates the input linearly
between two samples (`ekf.step`, ``input_hold="linear"``): across a rate step at a
fraction ``τ/dt`` of the interval, uniform on [0, 1), the integrated angle is off by
``Δω (dt/2 − τ)``, of variance ``Δω² dt² / 12`` (and up to ``Δω dt / 2``). No later sample
corrects it: the attitude keeps the error. At 100 m/s on an arc of 100 m radius entered
without a transition, ``Δω`` is 1 rad/s and the error up to 5 mrad, five times the
tactical filter's yaw σ; through a 10-g centripetal acceleration the yaw error is also an
error of ``s`` (``δs = δψ/κ``: the along-track share of the centripetal acceleration
must vanish), so the filter ended the curve 0.6 m off with σ_s 0.1 m (NEES 45 for 7 states
after the entry, 13 000 after the exit).

`JointRateNoise` gives the filter that variance as process noise: for each step of the
predicted path that crosses such a joint, the gyro white-noise density of the axis gets
``Δω² dt / 12`` more (the step's process noise is ``dt·q``), so that the attitude's
σ grows by exactly the sampling error's σ at the joint. Where the predicted crossing is
off by a step or a few, the attitude still gets the variance once (the error is a jump,
whenever it happens). Clothoids (the rate is continuous, its slope steps) leave an error
of order ``Δ(dω/dt) dt³``, far below the gyros' white noise, and get nothing.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["JointRateNoise", "SAMPLING_VARIANCE_FACTOR"]

Array = npt.NDArray[np.float64]

#: The variance of ``dt/2 − τ`` for ``τ`` uniform on [0, dt), in units of ``dt²``.
SAMPLING_VARIANCE_FACTOR = 1.0 / 12.0


def _rate_jumps(track) -> tuple[Array, Array, Array]:
    """Joints (m) with a step of ``dA/ds`` or ``dϑ/ds``, and the steps (1/m)."""
    table = track.table
    grade_rate = (table.elevation1 - table.elevation0) / table.length
    d_kappa = table.curvature0[1:] - table.curvature1[:-1]
    d_grade = grade_rate[1:] - grade_rate[:-1]
    keep = (d_kappa != 0.0) | (d_grade != 0.0)
    return table.s_start[1:][keep], d_kappa[keep], d_grade[keep]


class JointRateNoise:
    """The extra gyro densities of the steps that cross rate-step joints (module docstring).

    Parameters
    ----------
    track : trackmodel.Track
    """

    def __init__(self, track) -> None:
        self.s_joint_m, self.d_kappa_1pm, self.d_grade_1pm = _rate_jumps(track)

    def crossed(self, s_prev_m: float, s_m: Array, offsets: Array) -> bool:
        """Whether the paths ``[s_prev_m, s_m] + offset`` (m) may cross a joint for any of
        `offsets` (m; `densities` of each path shifted so): False only when none does.

        The shifted paths' extremes are the path's plus the offset, rounded (rounding is
        monotonic): a joint one of them crosses lies in ``(min + min(offsets),
        max + max(offsets)]``."""
        if self.s_joint_m.size == 0:
            return False
        lo = min(s_prev_m, float(np.minimum.reduce(s_m))) + float(np.min(offsets))
        hi = max(s_prev_m, float(np.maximum.reduce(s_m))) + float(np.max(offsets))
        return bool(np.any((self.s_joint_m > lo) & (self.s_joint_m <= hi)))

    def densities(self, s_prev_m: float, s_m: Array, speed_mps: float,
                  step_s: Array) -> tuple[npt.NDArray[np.intp], Array] | None:
        """Samples whose step follows a joint crossing, and their extra gyro densities.

        Parameters
        ----------
        s_prev_m : float
            Predicted ``s`` at the sample before the first, m.
        s_m : ndarray, shape (M,)
            Predicted ``s`` at the samples, m.
        speed_mps : float
            Speed, m/s.
        step_s : ndarray, shape (M,)
            Length of the step that starts at each sample, s.

        Returns
        -------
        None when no joint is crossed, else
        rows : ndarray of int, shape (J,)
            Samples (into `s_m`) whose step gets the extra noise: the first step after
            the predicted crossing of each joint.
        q : ndarray, shape (J, 2)
            Extra white-noise density of the gyro y and z axes, (rad/s)²·s.
        """
        if self.s_joint_m.size == 0:
            return None
        path = np.concatenate([[s_prev_m], np.asarray(s_m, dtype=float)])
        lo, hi = float(path.min()), float(path.max())
        j = np.flatnonzero((self.s_joint_m > lo) & (self.s_joint_m <= hi))
        if j.size == 0:
            return None
        # the sample at which the path has passed each joint (either direction)
        rows = np.empty(j.size, dtype=np.intp)
        for k, joint in enumerate(self.s_joint_m[j]):
            side = path >= joint
            rows[k] = int(np.flatnonzero(side[1:] != side[:-1])[0])
        dt = np.asarray(step_s, dtype=float)[rows]
        scale = SAMPLING_VARIANCE_FACTOR * speed_mps ** 2 * dt
        q = np.column_stack([scale * self.d_grade_1pm[j] ** 2, scale * self.d_kappa_1pm[j] ** 2])
        return rows, q
