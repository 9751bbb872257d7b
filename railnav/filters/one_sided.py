r"""A bound on what the curvature pseudo-observation can tell about ``s`` near an onset.

Where a straight meets a curve (a clothoid, an arc or a vertical curve: the joints between
a loxodrome section and one that is not, `onsets`), the pseudo-observation
(`railnav.filters.geometry_noise`) mostly says *on which side of the joint* the train is:
"no centripetal acceleration yet" means ``s < c``, "some" means ``s > c`` (the size of the
acceleration adds more only once the train is well into a clothoid). That is one-sided,
inequality information. With ``s ~ N(μ, σ²)`` its exact posterior is the prior truncated at
``c``; the EKF instead takes the statistically linearized row as a line in ``s`` and its
posterior variance does not depend on which side the measurement says. When σ is large
against ``|μ − c|`` the line lends ``s`` far more information than the truncation holds.
Measured on ``outage_20min`` seed 5 (tactical, 20-min outage, ``curvy``): at the clothoid
start (9343.6 m) the estimate is 122 m (3.3σ) ahead of the truth; from 520 to 525 s the
rows took σ_s from 37 to 7.2 m with an 88-m error, where the truncated prior keeps about
21 m; the curvature rows then made a 16σ speed update and σ_s fell to 0.19 m for good
(end of the trip: −14 km, σ_s 6.8 m). With the bound: σ_s 19.5 m at 525 s, end −1.0 m
(σ_s 0.90 m).

**The bound.** Whatever the measurement shows, the posterior of ``s`` is the prior
truncated on one side of ``c``, so its variance is at least the smaller of the two
truncations' variances, the one that keeps the side away from ``μ`` (`floor_variance`):
with ``β = −|c − μ|/σ`` and ``λ = φ(β)/Φ(β)`` (Mills' ratio, computed with ``erfcx`` so
that it holds far in the tail),

``Var[s | s < c] = σ² (1 − β λ − λ²)``   (`truncated_variance`).

**Per episode, not per chunk.** An *episode* starts at the first input chunk (≤ 1 s of
IMU samples) whose chunk-end estimate has an onset within ±`WINDOW_SIGMAS`·σ_s, and
lasts while that onset stays within the window of the episode's prior propagated at
constant speed (``Φ P_(s,v) Φᵀ``). What "not past ``c`` yet" says over many chunks is
one truncation of that prior, not one per chunk: applied chunk by chunk from each
chunk's own prior, the floor re-cut a prior already cut, and on seed 5 σ_s still fell
32 → 25 → 15 → 6 → 0.2 m over 526–530 s (end −14 km as without it). So the episode has a
budget of precision of ``s``: ``1/floor − 1/σ_ep²`` of its propagated prior (at the
chunk-end mean), less what the earlier chunks used. The used share is measured from the
filter's own variance (its prior against the previous chunk's prediction, so that it is
the EKF's real information and not this module's model of it). Each chunk's floor is then
``1/(1/σ²_prior + remaining budget)``. Where the rows would leave less variance at the
chunk's end, `OneSidedLimit` scales their whole noise density
(``S_c = D Q_c Dᵀ + R_c``: the accelerometer's white noise plus the geometry noise
``r_c``) by the smallest factor ``λ_R ≥ 1`` that meets the floor:
``r_c ← λ_R (r_c + D Q_c Dᵀ) − D Q_c Dᵀ``. With the budget spent the rows are switched
off (``λ_R`` = `MAX_INFLATION`) until the episode ends. The EKF then draws at most the
truncation's information from the rows; its mean moves less too, because the gain
shrinks with the information.

**How the rows' information is counted.** Over the ``(s, v)`` block only, referred to the
chunk's end: each sample's rows have ``∂h/∂s = −v² P⊥ d²u/ds²`` and
``∂h/∂v = −2v P⊥ du/ds`` (the statistically linearized slope and value the filter uses,
`strapdown.reduced`), ``δs_k = δs_end − (t_end − t_k) δv``, and the information is
``Σ_k Hᵀ S_c⁻¹ H Δt_k`` (the engine's step uses ``R = S_c/Δt``). ``D Q_c Dᵀ`` is taken as
``diag(q_fy, q_fz)`` (body y and z along the track's lateral and normal: mounting and
attitude angles of milliradians). The prior of the chunk's end is ``Φ P_(s,v) Φᵀ`` (no
process noise over ≤ 1 s). Leaving the attitude and bias states out overstates the
rows' information on ``s`` (they share the residual), so the factor errs on the safe side.

**When it acts** (else ``r_c`` is returned unchanged, the same array: bit-identical runs):
σ_s at the chunk's end above `geometry_noise.STATISTICAL_MIN_SIGMA_M` (2 m; with GNSS σ_s
is decimetres, and an episode ends when σ_s falls to 2 m), an onset within the window, and
the rows' variance below the floor. Far from an onset the floor, ``≈ σ²/β²``, is below
what the rows give, so it never acts there.

Limits:

- One onset per episode (the nearest at its start); two onsets within the window would
  each cut the prior.
- Within the window it gives up the information that a clothoid's growing curvature
  carries past the onset.
- With the budget spent the rows' attitude information is lost too, for the episode's
  few seconds.
- The attitude rows (`railnav.filters.attitude_rows`) have their own geometry noise and
  are not bounded here.
- A discrete update during an episode (GNSS back) counts as used precision until σ_s
  falls below 2 m and ends the episode.
- The network navigator's Gaussian sum (`railnav.navigation.s_split`) runs its
  hypotheses without it: its components carry the truncation themselves (on
  ``bench_network_outage`` seed 5 the mixture's probability below the truth at the
  clothoid, 0.05 at 527 s, is the truncated prior's, 0.043). A bound that widens one
  hypothesis's rows widens the common covariance of the continuous evidence (the widest
  S over the hypotheses) and blinds the weights: with it, seed 5 was lost for good.
  With the evidence on each hypothesis's S without the bound's share it is no longer
  lost, but no better than without the bound (156 against 154 confidently wrong
  seconds over 20 seeds, one at 6.5σ): a split component is a new filter, whose
  episode starts afresh from the narrower component, and below σ_s = 2 m it ends.

Units: m, s, m/s; densities in (m/s²)²·s.
"""
from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy.special import erfcx

from railnav.filters.geometry_noise import STATISTICAL_MIN_SIGMA_M
from strapdown.reduced import TRACK_PARAMETER_NAMES, cross_track_basis

__all__ = ["OneSidedLimit", "onsets", "truncated_variance", "floor_variance",
           "WINDOW_SIGMAS", "MAX_INFLATION"]

Array = npt.NDArray[np.float64]

#: An onset farther than this many σ_s from the chunk-end estimate is not looked at (the
#: geometry noise's quadrature window, `geometry_noise.QUADRATURE_HALF_WIDTH`).
WINDOW_SIGMAS = 4.0
#: The largest density factor searched (the rows then carry no information worth keeping).
MAX_INFLATION = 1e12
#: Bisection steps on ``log λ_R`` (relative precision ``log(MAX_INFLATION)·2⁻ⁿ``).
_BISECTION_STEPS = 48

_U = slice(TRACK_PARAMETER_NAMES.index("u_E"), TRACK_PARAMETER_NAMES.index("u_U") + 1)
_DU = slice(TRACK_PARAMETER_NAMES.index("du_E_ds"), TRACK_PARAMETER_NAMES.index("du_U_ds") + 1)
_D2U = slice(TRACK_PARAMETER_NAMES.index("d2u_E_ds2"),
             TRACK_PARAMETER_NAMES.index("d2u_U_ds2") + 1)
_SQRT_2_OVER_PI = math.sqrt(2.0 / math.pi)
#: Below this β the closed form loses digits to cancellation and the tail series is used.
_TAIL_BETA = -100.0


def truncated_variance(beta):
    """Variance of a standard normal truncated to ``(−∞, β]``: ``1 − βλ − λ²``,
    ``λ = φ(β)/Φ(β) = √(2/π) / erfcx(−β/√2)`` (stable for any β; → 1/β² as β → −∞).

    Parameters
    ----------
    beta : float or ndarray
        Upper truncation point in standard deviations.

    Returns
    -------
    float or ndarray
        The variance, in units of the untruncated variance (in (0, 1)).
    """
    beta = np.asarray(beta, dtype=float)
    lam = _SQRT_2_OVER_PI / erfcx(-beta / math.sqrt(2.0))
    out = 1.0 - beta * lam - lam ** 2
    # far in the lower tail the difference cancels: the series 1/β² − 6/β⁴ there instead
    b2 = np.maximum(beta ** 2, 1.0)
    out = np.where(beta < _TAIL_BETA, (1.0 - 6.0 / b2) / b2, out)
    return float(out) if out.ndim == 0 else out


def floor_variance(*, mean_m: float, sigma_m: float, onset_m: float) -> float:
    """The smaller variance of ``N(mean, σ²)`` truncated at `onset_m` to either side (the
    side away from the mean), m² (module docstring)."""
    return sigma_m ** 2 * truncated_variance(-abs(onset_m - mean_m) / sigma_m)


def onsets(track) -> Array:
    """Along-track distances (m) of the joints between a loxodrome section (a straight of
    constant grade) and one that is not (a curve, a clothoid, a vertical curve)."""
    table = track.table
    lox = table.is_loxodrome
    return table.s_start[1:][lox[1:] != lox[:-1]]


class OneSidedLimit:
    """Scales the pseudo-observation's noise density where it would tell ``s`` more than
    the side of an onset (module docstring).

    Parameters
    ----------
    track : trackmodel.Track
    layout : ekf.layout.StateLayout
        The filter's state layout (``s`` and ``v``).
    noise_names : sequence of str
        The process noise names (the accelerometer's ``w_fy``, ``w_fz``).
    """

    def __init__(self, track, layout, noise_names) -> None:
        self.onsets_m = onsets(track)
        self._i_s, self._i_v = layout.index("s"), layout.index("v")
        self._w_f = [list(noise_names).index(n) for n in ("w_fy", "w_fz")]
        #: The episode near one onset: its onset, start time, prior block of ``(s, v)``,
        #: the precision of ``s`` used so far, and the latest chunk's end and predicted
        #: variance (None: no episode).
        self._episode: dict | None = None
        #: The factor of the latest chunk that was scaled, and how many were (diagnostics).
        self.last_factor = 1.0
        self.chunks_scaled = 0

    def __call__(self, t: Array, s_pred: Array, params: Array, r_c: Array, x_prev: Array,
                 P_prev: Array, q_c: Array, t_prev: float) -> Array:
        """`r_c` of the chunk's samples, scaled where the floor is not met.

        Parameters
        ----------
        t : ndarray, shape (M,)
            Sample times, s.
        s_pred : ndarray, shape (M,)
            The predicted path, m.
        params : ndarray, shape (M, 16)
            The track parameters the rows use (statistically linearized).
        r_c : ndarray, shape (M, 2)
            The geometry noise densities, (m/s²)²·s.
        x_prev, P_prev : ndarray, shapes (n,), (n, n)
            The chunk's prior, at `t_prev`.
        q_c : ndarray, shape (n_w,) or (M, n_w)
            The process noise densities of the samples.
        t_prev : float
            s.

        Returns
        -------
        ndarray, shape (M, 2)
            `r_c` itself when nothing is scaled, else a scaled copy.
        """
        if self.onsets_m.size == 0:
            return r_c
        block = P_prev[np.ix_([self._i_s, self._i_v], [self._i_s, self._i_v])]
        t_end, mean = float(t[-1]), float(s_pred[-1])
        prior = _propagated(block, t_end - float(t_prev))
        episode = self._follow(block, prior, mean, float(t_prev), t_end)
        if episode is None:
            return r_c
        floor = self._floor(episode, prior[0, 0], mean, t_end)
        accel = np.atleast_2d(q_c)[:, self._w_f]                   # (1 or M, 2)
        density = r_c + accel
        info = self._information(t, s_pred, params, float(x_prev[self._i_v]), density,
                                 t_prev)
        try:
            prior_info = np.linalg.inv(prior)
        except np.linalg.LinAlgError:                               # v known exactly
            return r_c
        factor = _factor_for(prior_info, info, floor)
        if factor <= 1.0:
            return r_c
        self.last_factor, self.chunks_scaled = factor, self.chunks_scaled + 1
        return factor * density - accel

    def _follow(self, block: Array, prior: Array, mean: float, t_prev: float,
                t_end: float) -> dict | None:
        """The episode this chunk belongs to (started, continued or ended here), with the
        precision of ``s`` the chunks before used (the filter's own variance against its
        prediction)."""
        ep = self._episode
        if ep is not None:
            ep["used"] += 1.0 / block[0, 0] - 1.0 / ep["predicted"]
            sigma = math.sqrt(_propagated(ep["block"], t_end - ep["t0"])[0, 0])
            if (block[0, 0] <= STATISTICAL_MIN_SIGMA_M ** 2
                    or abs(ep["onset"] - mean) > WINDOW_SIGMAS * sigma):
                ep = None
        if ep is None:
            sigma = math.sqrt(max(prior[0, 0], 0.0))
            onset = float(self.onsets_m[int(np.argmin(np.abs(self.onsets_m - mean)))])
            if sigma > STATISTICAL_MIN_SIGMA_M and abs(onset - mean) <= WINDOW_SIGMAS * sigma:
                ep = {"onset": onset, "t0": t_prev, "block": block, "used": 0.0}
        if ep is not None:
            ep["predicted"] = prior[0, 0]
        self._episode = ep
        return ep

    @staticmethod
    def _floor(ep: dict, prior_var: float, mean: float, t_end: float) -> float:
        """The variance of ``s`` the chunk's end must keep, m²: the prior's precision plus
        what is left of the truncation's (of the episode's prior, propagated to `t_end`,
        at the current mean), less what the episode's chunks used."""
        var = _propagated(ep["block"], t_end - ep["t0"])[0, 0]
        sigma = math.sqrt(var)
        allowed = 1.0 / floor_variance(mean_m=mean, sigma_m=sigma, onset_m=ep["onset"]) \
            - 1.0 / var
        return 1.0 / (1.0 / prior_var + max(allowed - ep["used"], 0.0))

    def _information(self, t: Array, s_pred: Array, params: Array, speed: float,
                     density: Array, t_prev: float) -> Array:
        """The rows' information on ``(s, v)`` at the chunk's end, 2×2 (module docstring)."""
        lateral, normal = cross_track_basis(params[:, _U])
        du = params[:, _DU] + params[:, _D2U] * (s_pred - params[:, 0])[:, None]
        slope = params[:, _D2U]
        h_s = -speed ** 2 * np.stack([np.einsum("mi,mi->m", lateral, slope),
                                      np.einsum("mi,mi->m", normal, slope)], axis=-1)
        h_v = -2.0 * speed * np.stack([np.einsum("mi,mi->m", lateral, du),
                                       np.einsum("mi,mi->m", normal, du)], axis=-1)
        lag = (t[-1] - t)[:, None]
        h_v_end = h_v - lag * h_s                                   # δs_k = δs_end − lag δv
        dt = np.diff(np.concatenate([[t_prev], t]))[:, None]
        w = dt / density
        return np.array([[np.sum(w * h_s * h_s), np.sum(w * h_s * h_v_end)],
                         [np.sum(w * h_s * h_v_end), np.sum(w * h_v_end * h_v_end)]])


def _propagated(block: Array, span_s: float) -> Array:
    """``Φ P Φᵀ`` of an ``(s, v)`` covariance over `span_s` at constant speed."""
    phi = np.array([[1.0, span_s], [0.0, 1.0]])
    return phi @ block @ phi.T


def _posterior_s_variance(prior_info: Array, info: Array, factor: float) -> float:
    """``[(P⁻¹ + J/λ_R)⁻¹]_ss`` of the 2×2 information forms."""
    m = prior_info + info / factor
    det = m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]
    return float(m[1, 1] / det) if det > 0.0 else math.inf


def _factor_for(prior_info: Array, info: Array, floor: float) -> float:
    """The smallest ``λ_R ≥ 1`` with a posterior variance of ``s`` at least `floor` (the
    variance grows monotonically with ``λ_R``), by bisection on ``log λ_R``."""
    if _posterior_s_variance(prior_info, info, 1.0) >= floor:
        return 1.0
    lo, hi = 0.0, math.log(MAX_INFLATION)
    for _ in range(_BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        if _posterior_s_variance(prior_info, info, math.exp(mid)) >= floor:
            hi = mid
        else:
            lo = mid
    return math.exp(hi)
