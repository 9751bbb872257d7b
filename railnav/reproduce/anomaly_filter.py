"""The adaptive navigation filter of Ivanov et al. 2021 (SEEDS.md §2, eqs. 18–32).

Two linear Kalman filters on the :mod:`ekf` engine, with the INS accelerations as control:

* horizontal (:data:`~railnav.reproduce.anomaly_models.HORIZONTAL`): :func:`ekf.predict_linear`, then
  :func:`ekf.kalman_update` with the GNSS position and the speed-sensor velocity;
* vertical (:data:`~railnav.reproduce.anomaly_models.VERTICAL`): :func:`ekf.correlated_step` with the
  differenced barometer ``ξ1(k+1) − φ ξ1(k)`` and the GNSS height ``ξ2(k+1)``, both written
  as functions of ``x_k`` (eqs. 23–24). The first sample is a plain update with ``ξ1(0)``
  (variance ``σ_BV²``) and ``ξ2(0)``: with it the differenced filter is exactly the
  optimal filter of the model with the baro noise as a state.

Anomaly test (eqs. 22, 25, 29, 30): the GNSS innovation ``ε`` of a channel with covariance
``S`` passes if ``εᵀε ≤ γ̃ tr S`` (:class:`ekf.Gate` ``kind="trace"``). As in eqs. 27–32, if
either channel's test fires, the GNSS parts of *both* channels are left out at that epoch
(``joint_rejection``; they come from the same receiver); the speed sensor and barometer are
always used. Integrity monitor (§2, Fig. 1): when no anomaly was signalled and the updated
baro-bias estimate satisfies ``|ΔH*| ≥ ΔH_max``, the horizontal GNSS fix is refused (the
paper writes ``ΔH* ≥ ΔH_max``; a bias of either sign is a height disagreement).

When a GNSS part is refused, eqs. 31–32 keep the speed-sensor and baro columns ``K_Γ2``,
``K_1`` of the gain computed *with* the GNSS rows, and do not say which covariance follows;
we update with the rows actually used (gain and covariance of the smaller update), which is
the optimal filter given the refusal.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd
import scipy.linalg as sla

from ekf.correlated import correlated_step
from ekf.gating import Gate
from ekf.layout import StateLayout
from ekf.linear import predict_linear
from ekf.update import kalman_update
from railnav.errors import ConfigError
from railnav.reproduce.anomaly_models import (
    HORIZONTAL,
    VERTICAL,
    AnomalyParams,
    HorizontalChannel,
    VerticalChannel,
    horizontal_channel,
    vertical_channel,
)
from railnav.reproduce.anomaly_sim import AnomalyData

__all__ = ["AdaptiveConfig", "AdaptiveRun", "run_adaptive_filter", "H_MEASUREMENTS",
           "V_MEASUREMENTS"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

#: Measurement vector of the horizontal channel (paper Ξ_Γ = [Ξ_Γ1; Ξ_Γ2]).
H_MEASUREMENTS = StateLayout.from_blocks([("gnss", ("gnss_north", "gnss_east")),
                                          ("speed", ("speed_north", "speed_east"))])
#: Measurement vector of the vertical channel (differenced baro, GNSS height).
V_MEASUREMENTS = StateLayout.from_blocks([("baro", 1), ("gnss", 1)])


@dataclass(frozen=True)
class AdaptiveConfig:
    """Which of the paper's adaptive parts are on.

    Attributes
    ----------
    trace_factor : float or None
        ``γ̃`` of the anomaly test (9 or 4 in the paper); ``None``: no test.
    baro_bias_max_m : float or None
        ``ΔH_max`` of the integrity monitor, m; ``None``: no monitor.
    joint_rejection : bool
        A test that fires in one channel refuses the GNSS in both (eqs. 27–32).
    paper_eq24_gain : bool
        Diagnostic only: the vertical gain as eq. 24 is printed,
        ``[B_yy⁻¹ + Φ_yx P Φ_yxᵀ]⁻¹`` (an erratum), i.e. ``B_yy⁻¹`` in place of the
        noise covariance ``B_yy`` (the anomaly test keeps the model's ``S``), and the
        vertical recursion started from the prior without the update at ``t_0``, as the
        paper's. It shows where the paper's figures come from; never use it to navigate.
    """

    trace_factor: float | None = 9.0
    baro_bias_max_m: float | None = None
    joint_rejection: bool = True
    paper_eq24_gain: bool = False

    def __post_init__(self) -> None:
        for name in ("trace_factor", "baro_bias_max_m"):
            value = getattr(self, name)
            if value is not None and not (np.isfinite(value) and value > 0.0):
                raise ConfigError(f"AdaptiveConfig.{name} must be None or a finite number "
                                  f"> 0, got {value!r}")

    @property
    def gate(self) -> Gate | None:
        """The engine's trace gate for ``trace_factor`` (``None`` without a test)."""
        if self.trace_factor is None:
            return None
        return Gate(kind="trace", scope="vector", trace_factor=self.trace_factor)


@dataclass(frozen=True, eq=False)
class AdaptiveRun:
    """Estimates and decisions at every sample ``t_k``.

    Attributes
    ----------
    t : ndarray, shape (N,)
        s.
    x_horizontal, x_vertical : ndarray, shape (N, 6) and (N, 4)
        Estimates in the ``HORIZONTAL`` / ``VERTICAL`` layouts.
    P_horizontal, P_vertical : ndarray, shape (N, 6, 6) and (N, 4, 4)
        Their covariances.
    trace_ratio_horizontal, trace_ratio_vertical : ndarray, shape (N,)
        ``εᵀε / tr S`` of each channel's GNSS innovation (the test fires above ``γ̃``).
    anomaly : ndarray of bool, shape (N,)
        The anomaly test fired (in either channel).
    integrity_refused : ndarray of bool, shape (N,)
        The integrity monitor refused the horizontal GNSS fix.
    gnss_used_horizontal, gnss_used_vertical : ndarray of bool, shape (N,)
    """

    t: Array
    x_horizontal: Array
    x_vertical: Array
    P_horizontal: Array
    P_vertical: Array
    trace_ratio_horizontal: Array
    trace_ratio_vertical: Array
    anomaly: Array
    integrity_refused: Array
    gnss_used_horizontal: Array
    gnss_used_vertical: Array

    def to_frame(self) -> pd.DataFrame:
        """One row per sample: ``t_s``, the estimates (state names + unit suffix), the
        two trace ratios and the decision flags."""
        units = {"pos": "_m", "vel": "_mps", "accel_bias": "_mps2", "height": "_m",
                 "v_up": "_mps", "baro_bias": "_m", "bias_a_up": "_mps2"}
        cols: dict[str, Array] = {"t_s": self.t}
        for layout, x in ((HORIZONTAL, self.x_horizontal), (VERTICAL, self.x_vertical)):
            for block, start, stop in layout.blocks:
                for i in range(start, stop):
                    cols[layout.names[i] + units[block]] = x[:, i]
        cols.update(trace_ratio_horizontal=self.trace_ratio_horizontal,
                    trace_ratio_vertical=self.trace_ratio_vertical, anomaly=self.anomaly,
                    integrity_refused=self.integrity_refused,
                    gnss_used_horizontal=self.gnss_used_horizontal,
                    gnss_used_vertical=self.gnss_used_vertical)
        return pd.DataFrame(cols)


class _Channels:
    """The two channels' computations at one epoch (matrices built once)."""

    def __init__(self, params: AnomalyParams, config: AdaptiveConfig,
                 data: AnomalyData) -> None:
        self.h: HorizontalChannel = horizontal_channel(params)
        self.v: VerticalChannel = vertical_channel(params)
        self.gate = config.gate
        self.data = data
        self.H_h = np.vstack([self.h.H_gnss, self.h.H_speed])
        self.R_h = sla.block_diag(self.h.R_gnss, self.h.R_speed)
        self.Q_h, self.Q_v = self.h.Q, self.v.Q
        self.Phi_yx, self.B_xy, self.B_yy = self.v.Phi_yx, self.v.B_xy, self.v.B_yy
        # the covariance the gain uses: B_yy, or the printed erratum B_yy⁻¹ (diagnostic)
        self.paper_eq24 = config.paper_eq24_gain
        self.R_v = np.linalg.inv(self.B_yy) if self.paper_eq24 else self.B_yy
        self.H_v0 = np.vstack([self.v.H_baro, self.v.H_gnss])
        self.R_v0 = np.diag([self.v.R_baro, self.v.R_gnss])

    def test(self, innov: Array, S: Array) -> tuple[bool, float]:
        """The anomaly test of one GNSS innovation; ``(passed, εᵀε / tr S)``."""
        ratio = float(innov @ innov) / float(np.trace(S))
        return self.gate is None or self.gate.passes(innov, S)[0], ratio

    def horizontal(self, k: int, x: Array, P: Array, use_gnss: bool
                   ) -> tuple[Array, Array, Array, Array]:
        """Horizontal estimate at ``t_k`` from the one at ``t_{k−1}`` (none before the first
        sample). Returns ``x, P`` and the GNSS innovation and its ``S`` (if used)."""
        d = self.data
        if k > 0:
            accel = d.accel_ins_mps2[k - 1, :2]
            x, P = predict_linear(x, P, self.h.Phi, self.Q_h, self.h.Psi @ accel)
        z = np.concatenate([d.gnss_pos_m[k], d.speed_mps[k]])
        rows = slice(None) if use_gnss else H_MEASUREMENTS.slice("speed")
        innov = z[rows] - self.H_h[rows] @ x
        x, P, rec = kalman_update(x, P, innov, self.H_h[rows], self.R_h[rows, rows])
        g = H_MEASUREMENTS.slice("gnss")
        return x, P, innov[g] if use_gnss else innov[:0], rec.S[g, g] if use_gnss else rec.S

    def vertical(self, k: int, x: Array, P: Array, use_gnss: bool
                 ) -> tuple[Array, Array, Array, Array]:
        """Vertical estimate at ``t_k``: a plain update at ``k = 0``, else
        :func:`ekf.correlated_step` from ``t_{k−1}`` with the differenced measurements."""
        d, v = self.data, self.v
        rows = np.ones(V_MEASUREMENTS.size, dtype=bool)
        rows[V_MEASUREMENTS.slice("gnss")] = use_gnss
        if k == 0:
            innov = np.array([d.baro_m[0], d.gnss_height_m[0] - v.gnss_offset_m]) - self.H_v0 @ x
            x_upd, P_upd, rec = kalman_update(x, P, innov[rows], self.H_v0[rows],
                                              self.R_v0[np.ix_(rows, rows)])
            if not self.paper_eq24:     # the printed recursion starts from the prior itself
                x, P = x_upd, P_upd
        else:
            control = np.array([d.accel_ins_mps2[k - 1, 2], d.gravity_mps2])
            Bu = v.Psi @ control
            y = np.array([d.baro_m[k] - v.baro_correlation * d.baro_m[k - 1], d.gnss_height_m[k]])
            offset = np.array([(v.H_baro @ Bu)[0], (v.H_gnss @ Bu)[0] + v.gnss_offset_m])
            innov = y - offset - self.Phi_yx @ x
            x, P, rec = correlated_step(x, P, innov[rows], self.Phi_yx[rows],
                                        self.R_v[np.ix_(rows, rows)], Phi=v.Phi, Q=self.Q_v,
                                        M=self.B_xy[:, rows], Bu=Bu)
        if not use_gnss:
            return x, P, innov[:0], rec.S
        g = V_MEASUREMENTS.slice("gnss")
        # the model's innovation covariance Φ_yx P Φ_yxᵀ + B_yy (eq. 30), whatever the gain used
        S_gnss = rec.S[g, g] if k == 0 else rec.S[g, g] + (self.B_yy - self.R_v)[g, g]
        return x, P, innov[g], S_gnss


def run_adaptive_filter(data: AnomalyData, params: AnomalyParams, config: AdaptiveConfig, *,
                        x0_horizontal: Array, x0_vertical: Array) -> AdaptiveRun:
    """Run both channels over ``data`` with the paper's adaptive logic.

    Parameters
    ----------
    data : AnomalyData
    params : AnomalyParams
        Model parameters (the same as the simulation's for a matched filter); the initial
        covariances are ``params.P0_horizontal`` and ``params.P0_vertical``.
    config : AdaptiveConfig
    x0_horizontal : ndarray, shape (6,)
        Prior estimate at ``t_0`` in the ``HORIZONTAL`` layout.
    x0_vertical : ndarray, shape (4,)
        Prior estimate at ``t_0`` in the ``VERTICAL`` layout.

    Returns
    -------
    AdaptiveRun

    Raises
    ------
    ConfigError
        Prior estimates of the wrong shape or not finite.
    ekf.FilterDivergedError
        A singular innovation covariance.
    """
    xh, xv = (np.asarray(x, dtype=float) for x in (x0_horizontal, x0_vertical))
    if xh.shape != (HORIZONTAL.size,) or xv.shape != (VERTICAL.size,) \
            or not (np.all(np.isfinite(xh)) and np.all(np.isfinite(xv))):
        raise ConfigError("x0_horizontal (6,) and x0_vertical (4,) must be finite vectors")
    Ph, Pv = np.diag(params.P0_horizontal), np.diag(params.P0_vertical)
    ch = _Channels(params, config, data)
    out = _Outputs(data.t)
    bias = VERTICAL.index("baro_bias")
    for k in range(data.t.size):
        xv_c, Pv_c, e_v, S_v = ch.vertical(k, xv, Pv, True)
        xh_c, Ph_c, e_h, S_h = ch.horizontal(k, xh, Ph, True)
        (pass_v, ratio_v), (pass_h, ratio_h) = ch.test(e_v, S_v), ch.test(e_h, S_h)
        anomaly = not (pass_v and pass_h)
        ok_v, ok_h = (not anomaly, not anomaly) if config.joint_rejection else (pass_v, pass_h)
        if not ok_v:
            xv_c, Pv_c, _, _ = ch.vertical(k, xv, Pv, False)
        refused = (config.baro_bias_max_m is not None and not anomaly
                   and abs(xv_c[bias]) >= config.baro_bias_max_m)
        if refused or not ok_h:
            xh_c, Ph_c, _, _ = ch.horizontal(k, xh, Ph, False)
        xh, Ph, xv, Pv = xh_c, Ph_c, xv_c, Pv_c
        out.store(k, xh, Ph, xv, Pv, (ratio_h, ratio_v, anomaly, refused, ok_h and not refused,
                                      ok_v))
    run = out.result()
    log.info("anomaly test fired at %d of %d epochs; integrity monitor refused %d",
             int(run.anomaly.sum()), run.t.size, int(run.integrity_refused.sum()))
    return run


class _Outputs:
    """Preallocated per-sample arrays of :class:`AdaptiveRun`."""

    def __init__(self, t: Array) -> None:
        n = t.size
        self.t = t
        self.xh, self.Ph = np.zeros((n, HORIZONTAL.size)), np.zeros((n, HORIZONTAL.size,
                                                                     HORIZONTAL.size))
        self.xv, self.Pv = np.zeros((n, VERTICAL.size)), np.zeros((n, VERTICAL.size,
                                                                   VERTICAL.size))
        self.ratios = np.zeros((n, 2))
        self.flags = np.zeros((n, 4), dtype=bool)

    def store(self, k: int, xh: Array, Ph: Array, xv: Array, Pv: Array,
              decisions: tuple[float, float, bool, bool, bool, bool]) -> None:
        self.xh[k], self.Ph[k], self.xv[k], self.Pv[k] = xh, Ph, xv, Pv
        self.ratios[k] = decisions[:2]
        self.flags[k] = decisions[2:]

    def result(self) -> AdaptiveRun:
        return AdaptiveRun(t=self.t, x_horizontal=self.xh, x_vertical=self.xv,
                           P_horizontal=self.Ph, P_vertical=self.Pv,
                           trace_ratio_horizontal=self.ratios[:, 0],
                           trace_ratio_vertical=self.ratios[:, 1], anomaly=self.flags[:, 0],
                           integrity_refused=self.flags[:, 1],
                           gnss_used_horizontal=self.flags[:, 2],
                           gnss_used_vertical=self.flags[:, 3])
