"""What a chunk's predicted path adds to the constrained filter's process noise density.

`railnav.filters.constrained.ConstrainedFilter.inputs` predicts the along-track path of a
chunk of IMU samples and linearizes the track along it. The steps along that path add to the
IMU grade's and oscillator's densities ``q_c`` (`PathNoise.step_q_c`, one row per sample):

* the bias steps of the scale factors and misalignments that the state does not carry
  (`railnav.filters.scale_noise`), over the spread of paths that σ_s allows
  (`railnav.filters.scale_noise.step_nodes`, `PathNoise.path_rows`: one grid lookup for
  all; a bank's hypotheses in one density call, `bias_together`);
* the accelerometer biases' steps from the along-track force
  (`railnav.filters.along_force_noise`, given by the filter);
* on a car body (``config.track_attitude`` or ``config.suspension_noise``) the sampling error
  of its suspension's rates (`railnav.filters.suspension_noise`).

An angular-rate step at a joint adds nothing: the samples are means over their
intervals (`railnav.simulation.joint_average`), whose trapezoid keeps the angle; the
blend of the sample that straddles the joint is the geometry remainder's
(`railnav.filters.geometry_noise`, "Interval means").
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from railnav.filters.attitude_config import TrackAttitudeConfig
from railnav.filters.scale_noise import path_bias_step_densities, weighted_path_densities
from railnav.filters.suspension_noise import sampling_densities
from strapdown.kinematics import BIAS_STATE_NAMES

__all__ = ["PathNoise", "bias_together"]

Array = npt.NDArray[np.float64]


class PathNoise:
    """The process noise density of a chunk's samples along its predicted path.

    Parameters
    ----------
    track : trackmodel.Track
    grid : railnav.filters.track_grid.TrackParameterGrid
        The filter's grid of `track`.
    q_c : ndarray, shape (n_w,)
        The IMU grade's and oscillator's densities (the model's noise order).
    noise_names : sequence of str
        The model's noise names (``w_wx``..., ``w_<bias>``).
    config : railnav.config.NavigatorConfig
        Its IMU grade, ``track_attitude`` and ``suspension_noise``.
    scale_elements : tuple
        The ``S + M`` elements the state carries (their steps are not noise).
    estimate_biases : bool
        Whether the state carries the IMU biases (their steps are then noise on them).
    """

    def __init__(self, track, grid, q_c: Array, noise_names, *, config, scale_elements,
                 estimate_biases: bool) -> None:
        self.track, self.grid, self.q_c = track, grid, q_c
        self.imu, self.scale_elements = config.imu, scale_elements
        names = list(noise_names)
        self._gyro = [names.index(n) for n in ("w_wx", "w_wy", "w_wz")]
        #: Whose suspension parameters give the gyros its sampling noise
        #: (`railnav.filters.suspension_noise`): the rows' config, else the defaults with
        #: ``config.suspension_noise``; None: a rigid vehicle.
        self._suspension = config.track_attitude or \
            (TrackAttitudeConfig() if config.suspension_noise else None)
        #: The bias states' noise columns (None without bias states).
        self.bias_noise = [names.index(f"w_{n}") for n in BIAS_STATE_NAMES] \
            if estimate_biases else None

    def step_q_c(self, pending: dict, found, along: Array | None = None) -> Array:
        """`q_c` for the samples of `pending` (the filter's ``_start_inputs``: ``t``,
        ``steps``, ``nodes``, ``speed``), with what the steps of the
        predicted path add (module docstring): `found`, the densities of the spread's
        paths (`path_bias_step_densities`'s, None without), and `along`, the step variances
        (M, 3) of the accelerometer biases from the along-track force, each sample's given
        to the step from it. Returns `q_c` itself when nothing is added, else (M, n_w)."""
        t, steps, nodes, speed = pending["t"], pending["steps"], pending["nodes"], \
            pending["speed"]
        bias = weighted_path_densities(nodes, found)
        if along is not None and along.any():
            extra = np.zeros((t.size, 6))
            extra[:, :3] = along
            bias = extra if bias is None else bias + extra
        body = None if self._suspension is None else \
            sampling_densities(self._suspension, steps[:t.size], speed)
        if bias is None and body is None:
            return self.q_c
        q = np.tile(self.q_c, (t.size, 1))
        if bias is not None:
            q[:, self.bias_noise] += bias
        if body is not None:
            q[:, self._gyro] += body
        return q

    def path_rows(self, s_pred: Array, s_prev: float, nodes: list[tuple[float, float]]
                  ) -> tuple[Array, Array]:
        """Grid rows of the spread's paths (`step_nodes`: the predicted path shifted by
        each node's offset, clamped to the track), ``(P, 16)`` at each path's sample
        before the first and ``(P, M, 16)`` at the samples: one grid lookup for all (the
        grid's rows are pure per row: the same numbers as path by path)."""
        length = self.track.length_m
        offsets = np.array([offset for offset, _ in nodes])
        s_paths = np.minimum(np.maximum(s_pred[None, :] + offsets[:, None], 0.0), length)
        s_prevs = np.minimum(np.maximum(s_prev + offsets, 0.0), length)
        rows = self.grid.parameters(np.concatenate([s_prevs, s_paths.ravel()]))[0]
        n_paths = offsets.size
        return rows[:n_paths], rows[n_paths:].reshape(n_paths, s_pred.size, -1)

    def path_bias(self, s_pred: Array, s_prev: float, speed: float, steps: Array,
                  nodes: list[tuple[float, float]]) -> Array | None:
        """The bias steps' densities along the spread's paths (`path_rows`), weighted
        and summed in the nodes' order (as `step_q_c` sums them); None when no path's
        input changes."""
        return weighted_path_densities(nodes, self.densities(
            self.path_rows(s_pred, s_prev, nodes), speed, steps))

    def densities(self, paths: tuple[Array, Array], speed: float, steps: Array):
        """`path_bias_step_densities` of `paths` (`path_rows`'s) with this IMU grade and
        the elements the state carries."""
        return path_bias_step_densities(*paths, speed, self.imu, steps,
                                        estimated=self.scale_elements)


def bias_together(noises: list[PathNoise], pending: list[dict]) -> list:
    """`path_bias_step_densities` of every pending input (the filters' ``_start_inputs``)
    that has paths, in one call when they share the IMU grade and the steps (else one by
    one), split back per input (None where an input has no paths)."""
    out: list = [None] * len(pending)
    have = [k for k, p in enumerate(pending) if p["paths"] is not None]
    if not have:
        return out
    imu, steps = noises[have[0]].imu, pending[have[0]]["steps"]
    estimated = noises[have[0]].scale_elements
    if any(noises[k].imu != imu or not np.array_equal(pending[k]["steps"], steps)
           or noises[k].scale_elements != estimated for k in have):
        for k in have:
            out[k] = noises[k].densities(pending[k]["paths"], pending[k]["speed"],
                                         pending[k]["steps"])
        return out
    counts = [pending[k]["paths"][0].shape[0] for k in have]
    found = path_bias_step_densities(
        np.concatenate([pending[k]["paths"][0] for k in have]),
        np.concatenate([pending[k]["paths"][1] for k in have]),
        np.repeat([pending[k]["speed"] for k in have], counts), imu, steps,
        estimated=estimated)
    if found is None:
        return out
    edges = np.cumsum([0, *counts])
    for k, a, b in zip(have, edges[:-1], edges[1:]):
        out[k] = (found[0][a:b], found[1][a:b])
    return out
