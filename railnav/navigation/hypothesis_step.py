r"""One cycle of every hypothesis's filter: propagate to the cycle's end, update there.

`EngineStepper` drives each hypothesis's own filter object (any kind that screens its
rows: `railnav.filters.protocol.FilterKind.banks`, or any kind with fixes) through the
EKF engine (`ekf.CdFilter`), over the same samples for all: from the previous cycle's end
``t[a]`` to this one's ``t[b]``, then the epoch's discrete update at ``t[b]`` when there is
one. The engine holds no hypothesis's state: it is reset to the hypothesis's posterior at
``t[a]`` (one engine per state layout serves all), the filter object computes the inputs
of the samples ``t[a..b]`` from that posterior (`Filter.inputs`), the engine propagates
(`ekf.CdFilter.propagate`) and updates with the epoch's rows built at the prior there
(`Filter.observations`, which screens them: `railnav.filters.fault_detection`), adding an
`ekf.EpochRows` jump covariance first as `ekf.CdFilter` does.

**Kinked joints.** A map's netelements may meet at a kink (a switch digitized as a corner:
5–11° in the Brussels network) where the vehicle runs a curve; the accelerometer
pseudo-observation of the inertial filters would take the curve's lateral acceleration for
an error of the state. Within `KINK_WINDOW_M` (plus 3σ_s) of an end of its track whose
joint kinks by more than `trackmodel.network.CONTINUOUS_KINK_RAD`, a hypothesis's
pseudo-observation noise density gets the curve a train would run there,
``(v²θ/w)² · w/|v|`` (θ the kink, ``w`` the window): the filter then leans on its IMU
through the joint. Such a cycle's continuous evidence is left out for every hypothesis
(`CycleOutcome.joint`), so that no hypothesis pays for the map's corner.

**Geometry noise.** Where a curvature change lies within a hypothesis's σ_s (a switch's
way leaving the straight, a curve's entry), its filter's pseudo-observation carries the
variance of the geometry over that window (`railnav.filters.geometry_noise`): a Gaussian
stand-in for "straight or curved". Scored as a likelihood it would penalize that
hypothesis for its wider Gaussian, though the vehicle may well be on the straight part; so
a cycle in which any hypothesis's geometry variance exceeds `GEOMETRY_VARIANCE_LIMIT` brings
no continuous evidence for anyone (`CycleOutcome.geometry`). Once the vehicle is clearly in
the curve (or clearly not), the evidence flows again, and it is strong.

What the weights need comes back per hypothesis: the epoch's screen (innovations at the
prior and their covariance, for the common evidence of `railnav.navigation.bank`'s
`common_log_likelihoods`) and the log-likelihood of the continuous measurement over the
cycle (the accelerometer pseudo-observation of the inertial filters: each step's
``−½(νᵀS⁻¹ν + log det S + n_c log 2π)`` from the step outputs, `ekf.propagate.StepOutputs`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ekf.packing import unpack_sym
from ekf.series import EpochRows, InputSeries
from ekf.update import LOG_2PI
from railnav.navigation.loop import filter_engine
from trackmodel.network import CONTINUOUS_KINK_RAD

__all__ = ["EngineStepper", "CycleOutcome", "continuous_log_likelihood", "KINK_WINDOW_M",
           "joint_allowance"]

Array = npt.NDArray[np.float64]

#: Half-width of the stretch around a kinked joint where the map's geometry is not
#: trusted by the pseudo-observation, m.
KINK_WINDOW_M = 10.0
#: A cycle's continuous evidence counts only while the geometry noise of every
#: hypothesis's pseudo-observation stays below this variance, (m/s²)² (module docstring).
GEOMETRY_VARIANCE_LIMIT = 1e-4


@dataclass(frozen=True, eq=False)
class CycleOutcome:
    """What one cycle gave each hypothesis (in the order they were stepped).

    Attributes
    ----------
    screens : list of EpochScreen or None
        Each filter's screened epoch (None for all when the cycle had no epoch).
    continuous_log_lik : ndarray, shape (K,)
        Log-likelihood of the continuous measurement over the cycle (0 without one).
    steps : int
        Filter steps made (summed over the hypotheses).
    joint : bool
        Some hypothesis ran near a kinked joint (module docstring).
    continuous : bool
        The filters have a continuous measurement (the inertial ones).
    geometry : bool
        Some hypothesis's geometry variance exceeded `GEOMETRY_VARIANCE_LIMIT`.
    """

    screens: list | None
    continuous_log_lik: Array
    steps: int
    joint: bool = False
    continuous: bool = False
    geometry: bool = False


def continuous_log_likelihood(outputs) -> float:
    """``Σ_k log N(ν_k; 0, S_k)`` of a span's continuous-measurement innovations.

    Parameters
    ----------
    outputs : ekf.propagate.StepOutputs
        With ``innov`` (N, n_c) and packed ``S`` (N, n_c(n_c+1)/2); n_c = 0 gives 0.
    """
    nu = np.asarray(outputs.innov)
    if nu.ndim != 2 or nu.shape[1] == 0 or nu.shape[0] == 0:
        return 0.0
    S = unpack_sym(outputs.S)
    _, logdet = np.linalg.slogdet(S)
    return float(-0.5 * np.sum(outputs.nis + logdet + nu.shape[1] * LOG_2PI))


def joint_allowance(h, tracks, t: Array) -> Array | None:
    """Extra pseudo-observation noise density at samples ``t`` near a kinked joint of the
    hypothesis's track (module docstring), shape (M,); None where there is none."""
    if tracks is None:
        return None
    joints = [(s_j, k) for s_j, k in tracks.joints(h.pieces) if k >= CONTINUOUS_KINK_RAD]
    if not joints:
        return None
    i_s, i_v = h.index("s"), h.index("v")
    v = float(h.x[i_v])
    s = h.s_m + v * (t - t[0])
    w = KINK_WINDOW_M + 3.0 * float(np.sqrt(max(h.P[i_s, i_s], 0.0)))
    near = np.zeros(t.size)
    for s_j, kink in joints:
        near = np.where(np.abs(s - s_j) < w, np.maximum(near, kink), near)
    if not near.any():
        return None
    speed = max(abs(v), 1.0)
    return (speed ** 2 * near / w) ** 2 * w / speed


class EngineStepper:
    """Steps hypotheses cycle by cycle over a trip's samples (module docstring).

    Parameters
    ----------
    config : railnav.config.NavigatorConfig
    t : ndarray, shape (M,)
        Sample times, s from the trip start.
    u : ndarray, shape (M, n_u)
        Raw inputs of the samples.
    """

    def __init__(self, config, t: Array, u: Array, tracks=None) -> None:
        self.config, self.t, self.u, self.tracks = config, t, u, tracks
        self._dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
        self._engines: dict[tuple, object] = {}

    def _engine(self, filt):
        key = (type(filt).__name__, filt.layout.names)
        if key not in self._engines:
            self._engines[key] = filter_engine(filt, self.config, sample_interval_s=self._dt)
        return self._engines[key]

    def step(self, hyps, a: int, b: int, epoch: int | None) -> CycleOutcome:
        """Propagate every hypothesis from sample `a` to sample `b` and update it there
        with epoch `epoch` (an index of the trip's epoch schedule; None: no epoch)."""
        screens = [] if epoch is not None else None
        log_lik = np.zeros(len(hyps))
        t, u = self.t[a:b + 1], self.u[a:b + 1]
        joint = continuous = geometry = False
        dt = np.diff(t)
        for k, h in enumerate(hyps):
            engine = self._engine(h.filt)
            engine.reset(h.x, h.P)
            if b > a:
                u_c, p_c, r_c = h.filt.inputs(t, u, h.x, h.P, float(t[0]))
                continuous = continuous or r_c is not None
                if r_c is not None and dt.size and not geometry:
                    variance = np.max(r_c[1:], axis=1) / np.maximum(dt, 1e-12)
                    geometry = bool(np.max(variance) > GEOMETRY_VARIANCE_LIMIT)
                extra = None if r_c is None else joint_allowance(h, self.tracks, t)
                if extra is not None:
                    r_c = r_c + extra[:, None]
                    joint = True
                out = engine.propagate(InputSeries(t=t, u=u_c, p=p_c, q_c=h.filt.q_c,
                                                   r_c=r_c))
                log_lik[k] = continuous_log_likelihood(out)
            if epoch is not None:
                rows = h.filt.observations(epoch, engine.x, engine.P)
                if isinstance(rows, EpochRows):
                    if rows.jump_covariance is not None:
                        engine.P = engine.P + rows.jump_covariance
                    rows = rows.observations
                engine.update(rows)
                screens.append(h.filt.screen.last)
                h.filt.screen.clear_records()
            h.x, h.P = engine.x.copy(), engine.P.copy()
        return CycleOutcome(screens, log_lik, (b - a) * len(hyps), joint, continuous,
                            geometry)
