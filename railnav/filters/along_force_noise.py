"""The along-track force's accelerometer-bias steps as the constrained filter's process
noise, chunk by chunk (`railnav.filters.constrained.ConstrainedFilter`).

`railnav.filters.along_force_steps.AlongForceSteps` is the envelope (what each sample's change of
the along-track specific force gives the biases, and what a tie takes back);
`AlongForceNoise` is its bookkeeping against the engine: the low-passed force carried
across chunks (`smoothed_along_force`), the tie at the first chunk after an epoch, the
step variances as densities of the step from each sample (a first sample that repeats the
previous chunk's last carries that sample's density), and the noise given told back to
the envelope as the engine integrates it, so that the total is the same however the
record is cut into chunks.
"""
from __future__ import annotations

import copy

import numpy as np
import numpy.typing as npt

from railnav.filters.along_force_steps import AlongForceSteps, smoothed_along_force
from strapdown.imu_errors import ImuErrors

__all__ = ["AlongForceNoise", "forces_together"]

Array = npt.NDArray[np.float64]


class AlongForceNoise:
    """One filter's along-force bias noise (module docstring).

    Parameters
    ----------
    steps : railnav.filters.along_force_steps.AlongForceSteps
    i_ax : int
        Index of ``b_ax`` in the state (``b_ay``, ``b_az`` follow).
    bias_noise : sequence of int
        Columns of the accelerometer biases' noises ``w_b_ax, w_b_ay, w_b_az`` in ``q_c``.
    """

    def __init__(self, steps: AlongForceSteps, i_ax: int, bias_noise) -> None:
        self.steps, self.i_ax, self.bias_noise = steps, int(i_ax), list(bias_noise)[:3]
        self.epoch = False          # an epoch's rows were built since the last chunk
        #: The latest chunk's last sample time and density row (`densities`).
        self.row: tuple[float, Array | None] = (-np.inf, None)
        #: The latest chunk's last accelerometer-bias noise row (`given`).
        self.q: Array | None = None
        #: The latest chunk's last sample ``(t, f_x, f_x low-passed)`` (`force`).
        self.last_f: tuple[float, float, float] | None = None

    @classmethod
    def for_grade(cls, imu: ImuErrors, i_ax: int, bias_noise) -> "AlongForceNoise | None":
        """The noise for `imu`; None when its accelerometers have no scale factor or
        misalignment (`AlongForceSteps.for_grade`)."""
        steps = AlongForceSteps.for_grade(imu)
        return None if steps is None else cls(steps, i_ax, bias_noise)

    def force(self, t: Array, u: Array) -> Array:
        """The specific force along the body x axis (traction, braking and the grade's
        share of gravity) at each sample, low-passed (`smoothed_along_force`), m/s², shape
        (M,): not bias-corrected (the envelope uses its changes only; a correction at each
        chunk's prior would make it depend on where the record is cut)."""
        smoothed, self.last_f = smoothed_along_force(t, u[:, 0], self.last_f)
        return smoothed

    def densities(self, along: Array, P_prev: Array, t: Array, steps: Array) -> Array:
        """Each sample's step variances over the chunk (`AlongForceSteps.chunk_variances`,
        tied when an epoch came since the last chunk) as densities of the step from it,
        (m/s²)²/s, shape (M, 3); a first sample that repeats the previous chunk's last (a
        network cycle starts at its predecessor's end) carries that sample's density,
        which the engine would otherwise have taken into this step from the previous
        chunk.

        Parameters
        ----------
        along : ndarray, shape (M,)
            `force` of the chunk's samples, m/s².
        P_prev : ndarray, shape (n, n)
            The covariance at the chunk's start.
        t, steps : ndarray, shapes (M,), (>= M,)
            The samples' times and the steps from them, s.
        """
        tie, self.epoch = self.epoch, False
        i = self.i_ax
        added = self.steps.chunk_variances(along, np.diag(P_prev)[i:i + 3], tie=tie)
        rows = added / np.maximum(steps[:t.size, None], 1e-9)
        last_t, last_row = self.row
        if last_row is not None and t[0] <= last_t:
            rows[0] = last_row
        self.row = (float(t[-1]), rows[-1].copy())
        return rows

    def given(self, step_q_c: Array, t: Array, t_prev: float) -> None:
        """Tell the envelope the process noise `step_q_c` gave the accelerometer biases
        from the chunk's start to its last sample as the engine integrates it (each
        sample's row over the step from it; the step into the first sample with the
        previous chunk's last row): the same total however the samples are cut."""
        q = np.atleast_2d(step_q_c)[:, self.bias_noise]
        into = q[0] if self.q is None else self.q
        total = into * (t[0] - t_prev) + np.sum(q[:-1] * np.diff(t)[:, None], axis=0) \
            if q.shape[0] > 1 else q[0] * (t[-1] - t_prev)
        self.q = q[-1].copy()
        self.steps.noise_given(total)

    def copy(self) -> "AlongForceNoise":
        """An independent copy (a hypothesis's child goes on from its parent's memory)."""
        return copy.deepcopy(self)


def forces_together(noises, t: Array, u: Array) -> list:
    """`AlongForceNoise.force` of several filters' noises (a bank's hypotheses; None: a
    filter without) over the same samples: computed once for the noises whose low-pass
    carries the same last sample (``last_f``, compared bit for bit: hypotheses stepped
    over the same cycles since their common start), each then left where its own call
    would leave it. Returns each noise's smoothed force (shared, read-only), in order."""
    out: list = [None] * len(noises)
    done: dict = {}
    for k, noise in enumerate(noises):
        if noise is None:
            continue
        key = None if noise.last_f is None else np.array(noise.last_f).tobytes()
        if key not in done:
            done[key] = (noise.force(t, u), noise.last_f)
        out[k], noise.last_f = done[key]
    return out
