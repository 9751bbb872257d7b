r"""An epoch's own fix on the track, for the divergence monitor (`railnav.navigation.monitor`).

`snapshot_fix`: an epoch's own position rows (the GNSS pseudoranges, or a position fix's
rows) solved alone on the track, linearised at the filter's prior, with the receiver's
single-point fault exclusion (`gnss_obs.raim.fault_detection_exclusion`). Fixes of the
whole trip projected on the track are `railnav.navigation.track_fixes`'s.
"""
from __future__ import annotations

import math
from functools import cache

import numpy as np
import numpy.typing as npt

__all__ = ["snapshot_fix", "SNAPSHOT_SUFFIX", "SNAPSHOT_FIX_MODEL"]

Array = npt.NDArray[np.float64]

#: Row models whose rows carry a single-epoch position on the track: the GNSS pseudoranges
#: of every track-based receiver model (``<name>_pseudorange``) and a fix's position rows.
SNAPSHOT_SUFFIX, SNAPSHOT_FIX_MODEL = "_pseudorange", "fix_position"


@cache
def _spp_defaults():
    """`gnss_obs.spp.SppConfig`'s defaults (read per epoch by `snapshot_fix`)."""
    from gnss_obs.spp import SppConfig
    return SppConfig()


def snapshot_fix(observations, x: Array, i_s: int, clock_columns=(), *,
                 pseudorange_inflation: float = 1.0) -> tuple[float, float, bool] | None:
    """This epoch's own fix on the track, relative to the prior: ``(δs, σ², white)``, or
    None.

    The rows are the ones the filter updates the prior ``x`` with (its
    `ekf.Observation` s, evaluated at ``x`` when they are an
    `ekf.update.EvaluatedObservations`). Of them, the position rows (`SNAPSHOT_SUFFIX`,
    `SNAPSHOT_FIX_MODEL`) are solved alone by weighted least squares, linearised at the
    prior, for ``s`` and the receiver clocks (`clock_columns`: unknown, so the prior's
    clock does not enter), every other state held at the prior; GNSS rows with the
    single-point solution's χ² fault exclusion and Huber weights
    (`gnss_obs.raim.fault_detection_exclusion` with `gnss_obs.spp.SppConfig`'s defaults).
    The solution ``s_prior + δs`` depends on this epoch's measurements only (to first order in the
    prior's error: the rows are exact to second order in ``s − s_prior``), so
    ``δs`` has the variance ``σ² + σ²_s,prior`` when both are right. It is linearised at
    the prior's ``s``, so a track that passes the same place twice (a loop) gives no
    ambiguous projection, unlike a position fix projected on the whole track.
    A filter that inflates its pseudorange variances for errors correlated in time (the
    gnss-only filter's ``pseudorange_inflation``, ×40 for τ = 20 s at 1 Hz: the weight of
    long averages; it inflates its code fixes' position rows alike) gives
    `pseudorange_inflation`; the snapshot keeps the inflated
    variances, and ``white`` is False: its error is then correlated with the prior's, and
    the lower tail (`railnav.navigation.small_disagreement`) does not hold (on the urban
    drive it fired on every epoch). Solving with ``R / inflation`` instead (one epoch's own
    σ) was tried: on the urban drive it said ``lost`` on 28 of 58 epochs of leg 2, where the gnss-only
    filter is right to 0.93 m RMS (single-epoch urban errors exceed that σ), and its
    restarts made the leg worse (1.21 m).
    None: fewer rows than unknowns, or a singular geometry.
    """
    from gnss_obs.raim import fault_detection_exclusion, wls_step
    if hasattr(observations, "observations"):            # ekf.EpochRows (a clock jump)
        observations = observations.observations
    if not observations:
        return None
    evaluated = getattr(observations, "innov", None) is not None \
        and observations.evaluated_at(x)
    rows, gnss = [], False
    start = 0
    for obs in observations:
        m = obs.z.size
        name = obs.model.name
        use = name.endswith(SNAPSHOT_SUFFIX) or name == SNAPSHOT_FIX_MODEL
        if use and np.ndim(obs.R) == 1:
            if evaluated:
                nu = observations.innov[start:start + m]
                H = observations.H[start:start + m]
            else:
                z_pred, H = obs.model.evaluate(x, obs.p)
                nu = obs.z.reshape(-1) - z_pred
            rows.append((nu, H, obs.R))
            gnss |= name.endswith(SNAPSHOT_SUFFIX)
        start += m
    if not rows:
        return None
    # one model's rows (an epoch's pseudoranges): their arrays as they are, else stacked
    nu, H, R = rows[0] if len(rows) == 1 else (np.concatenate(a) for a in zip(*rows))
    cols = [i_s] + [c for c in clock_columns if np.count_nonzero(H[:, c])]   # any != 0
    A = H.take(cols, axis=1)       # C-ordered (H[:, cols] is not): no copies in the FDE
    if nu.size < len(cols) or not np.count_nonzero(A[:, 0]):
        return None
    sigma = np.sqrt(np.asarray(R, dtype=float))
    try:
        if gnss and nu.size > len(cols):
            spp = _spp_defaults()           # the receiver's own SPP exclusion and weights
            step = fault_detection_exclusion(A, nu, sigma, p_false_alarm=spp.p_false_alarm,
                                             max_exclusions=spp.max_exclusions,
                                             huber_k=spp.huber_k).step
        else:
            step = wls_step(A, nu, sigma)
    except np.linalg.LinAlgError:
        return None
    ds, var = float(step.dx[0]), float(step.cov[0, 0])
    if not (math.isfinite(ds) and math.isfinite(var) and var > 0.0):
        return None
    return ds, var, pseudorange_inflation == 1.0

