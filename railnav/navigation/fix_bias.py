r"""The position fixes' Gauss–Markov bias in the network navigator's evidence.

A receiver without corrections errs by white noise plus a bias that wanders over a minute
(issue 13's single-point quality: 2 m white + 2 m Gauss–Markov, τ 60 s, per horizontal
axis). `NetworkNavConfig.evidence_correlation_s` alone treats the whole error as
correlated: every epoch after the first counts ``(1 − ρ)/(1 + ρ)`` (0.003 at 2.5 Hz and
τ 60 s). That is the exact share for a purely first-order Markov error, and far too little
when half the variance is white. The first fix then decides the start: its white error
counts whole, and the next minute's fixes barely count at all. And the fixes that follow
a switch cannot tell its ways apart in time.

With `NetworkNavConfig.fix_bias_sigma_m` = σ_b > 0, each hypothesis carries its own
estimate of that bias ``b = (east, north)`` (`FixBias`, the track bank's "every hypothesis
its own filter" applied to the fixes' error). At each fix:

* **Propagation** over Δt since the hypothesis's last fix: ``b ← ρ b``,
  ``P_b ← ρ² P_b + σ_b² (1 − ρ²) I``, ``ρ = e^{−Δt/τ}`` (τ =
  `NetworkNavConfig.evidence_correlation_s`; τ = 0: the bias is new at every fix);
  a new hypothesis starts from the stationary prior ``(0, σ_b² I)``.
* **The cross-track row** (`railnav.filters.fix_rows`: its innovation ``ν`` does not
  depend on the filter's state, its variance ``R`` is the fix's white error across the
  track plus the map's) is predicted as ``ν ~ N(c·b, c P_b cᵀ + R)``, ``c`` the track's
  horizontal cross unit vector (east, north). Its log-density is the row's exact share of
  the sequence's likelihood, ``p(ν_1..ν_n) = Π_k p(ν_k | ν_1..ν_{k−1})``, so it counts
  whole at every epoch (`CycleOutcome.evidence_whole`); the bias is then updated with it
  (scalar Kalman update).
* **The along-track and speed rows** keep the share: their correlated part is absorbed
  by ``s`` and ``v``, which this model does not separate from the bias.

Children (a switch's ways, `railnav.navigation.hypotheses.branch`) inherit their parent's
bias: what the fixes said about the bias before the joint is what tells the ways apart
after it. Merged hypotheses get the moment-matched bias (`merged`). The IMM restarts
(`railnav.navigation.network_weights.mix_states`) leave each hypothesis its own bias: at
the crossing rate (1e-5/s) the mixing weights are the identity to 1e-5, and blending the
estimates of two parallel tracks would throw away the very offset that tells them apart.

Only the fix-only runs' stepper (`railnav.navigation.stacked_fixes`) models it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ekf.bank import merge_gaussians
from ekf.update import LOG_2PI

__all__ = ["FixBias", "cross_row_evidence", "with_fix_bias", "merged"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class FixBias:
    """A hypothesis's estimate of the fixes' horizontal bias (module docstring).

    Attributes
    ----------
    mean_m : ndarray, shape (2,)
        East, north, m.
    cov_m2 : ndarray, shape (2, 2)
    time_s : float
        The fix it was last updated with, s from the trip start.
    """

    mean_m: Array
    cov_m2: Array
    time_s: float


def cross_row_evidence(biases, cross_en: Array, nu: Array, R: Array, time_s: float, *,
                       sigma_m: float, tau_s: float) -> tuple[Array, list[FixBias]]:
    """Each hypothesis's log-density of its cross-track fix row given its bias, and the
    updated biases (module docstring).

    Parameters
    ----------
    biases : sequence of FixBias or None, length K
        None: a new hypothesis (the stationary prior).
    cross_en : ndarray, shape (K, 2)
        The track's horizontal cross unit vector (east, north) at each hypothesis.
    nu, R : ndarray, shape (K,)
        The cross row's innovation (m) and white variance (m²).
    time_s : float
        The fix's time, s.
    sigma_m, tau_s : float
        σ_b > 0 (m) and τ >= 0 (s) of the bias per axis.

    Returns
    -------
    log_lik : ndarray, shape (K,)
    updated : list of FixBias, length K
    """
    K = len(biases)
    var_b = sigma_m * sigma_m
    b, P = np.zeros((K, 2)), np.tile(var_b * np.eye(2), (K, 1, 1))
    for k, e in enumerate(biases):
        if e is not None:
            rho = math.exp(-max(time_s - e.time_s, 0.0) / tau_s) if tau_s > 0.0 else 0.0
            b[k] = rho * e.mean_m
            P[k] = rho * rho * e.cov_m2 + var_b * (1.0 - rho * rho) * np.eye(2)
    c = np.asarray(cross_en, dtype=float)
    Pc = np.einsum("kij,kj->ki", P, c)
    v = np.einsum("ki,ki->k", c, Pc) + np.asarray(R, dtype=float)
    r = np.asarray(nu, dtype=float) - np.einsum("ki,ki->k", c, b)
    log_lik = -0.5 * (r * r / v + np.log(v) + LOG_2PI)
    gain = Pc / v[:, None]
    b = b + gain * r[:, None]
    P = P - np.einsum("ki,kj->kij", gain, Pc)
    P = 0.5 * (P + P.transpose(0, 2, 1))
    return log_lik, [FixBias(b[k], P[k], float(time_s)) for k in range(K)]


def with_fix_bias(hyps, azimuth_rad: Array, keys, nu: Array, variances: Array,
                  evidence: Array, time_s: float, *, sigma_m: float, tau_s: float
                  ) -> tuple[Array, Array]:
    """An epoch's fix evidence split into what the share applies to (`evidence` without
    the cross-track row's white-error term) and the cross row's term given each
    hypothesis's bias (`cross_row_evidence`; `hyps`' ``fix_bias`` updated). The cross row
    does not depend on the state (``∂/∂[s, v] = 0``): its innovation covariance is its
    ``R``, uncorrelated with the other rows', so its term separates from the joint
    density exactly.

    Parameters
    ----------
    hyps : list of railnav.navigation.hypotheses.Hypothesis, length K
    azimuth_rad : ndarray, shape (K,)
        The track's azimuth at each hypothesis (cross = (cos A, −sin A), east/north).
    keys : sequence of str, length m
        The fix's row keys (one ends with ``/fix_cross``).
    nu, variances : ndarray, shape (K, m)
        Innovations (m) and their variances (m²).
    evidence : ndarray, shape (K,)
        The epoch's log-likelihood over all its rows.
    time_s, sigma_m, tau_s : float
        As `cross_row_evidence`.

    Returns
    -------
    shared, whole : ndarray, shape (K,)
    """
    j = [str(k).endswith("/fix_cross") for k in keys].index(True)
    nu_c, R = nu[:, j], variances[:, j]
    white = -0.5 * (nu_c * nu_c / R + np.log(R) + LOG_2PI)
    A = np.asarray(azimuth_rad, dtype=float)
    whole, biases = cross_row_evidence([h.fix_bias for h in hyps],
                                       np.column_stack([np.cos(A), -np.sin(A)]), nu_c, R,
                                       time_s, sigma_m=sigma_m, tau_s=tau_s)
    for h, e in zip(hyps, biases):
        h.fix_bias = e
    return evidence - white, whole


def merged(weights: Array, biases) -> FixBias | None:
    """The moment-matched bias of hypotheses merged with `weights` (those without one
    left out; None when none has one)."""
    have = [(float(w), e) for w, e in zip(np.asarray(weights, float).tolist(), biases)
            if e is not None]
    if not have:
        return None
    if len(have) == 1:
        return have[0][1]
    w = np.array([x for x, _ in have])
    mean, cov = merge_gaussians(w / w.sum(), np.array([e.mean_m for _, e in have]),
                                np.array([e.cov_m2 for _, e in have]))
    return FixBias(mean, cov, max(e.time_s for _, e in have))
