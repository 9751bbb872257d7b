r"""A grade the track does not know: what it does to an inertial filter, and its noise.

A network without heights (`trackmodel.network.Network.heights` False: OpenStreetMap, tp-lib's
GeoJSON) is fitted at ``h = 0``, level. A train on it climbs the real grade ``γ`` all the
same: its body is pitched by ``γ`` and its velocity is inclined by ``γ``. The constrained
filter (`strapdown.reduced`) takes the track's tangent ``u`` as level, so

* **the start.** A filter started from a fix takes the track's pitch, 0, with the
  configured attitude σ (1 mrad), while the body is pitched by ``γ`` (10-20 mrad on a
  main line): along-track gravity ``g γ`` (0.1-0.2 m/s²) leaks into the speed at once.
  The start's pitch variance gets ``σ_γ²`` (`NavigatorConfig.track_grade_sigma_rad`,
  `railnav.filters.ins_clock_model.initial_variances`);
* **the pseudo-observation's normal row.** ``n·(a_n − v² du/ds) = 0`` with ``n`` the level
  track's normal (up), while the train's acceleration ``a`` is along the inclined tangent:
  the row reads ``a sin γ`` that the model does not have. During an acceleration it then
  holds the body's pitch to the level track's (the pitch follows ``−γ`` off the truth)
  and the along-track accelerometer bias takes ``g γ`` instead: a filter that is sure of
  both and wrong in both;
* **the track-attitude pitch row** (``NavigatorConfig.track_attitude``,
  `railnav.filters.attitude_rows`: ``θ_b − ϑ(s)``) would hold the body's pitch to the
  level track's, off by the whole grade: it is left out (yaw and roll rows kept).

Its noise. The term ``a γ`` is the train's along-track acceleration ``a`` (known to the
filter's prediction, `unknown_grade_density`'s ``accel_mps2``: ``f_x − b_ax − g sin θ`` at
each sample, the one `ConstrainedFilter.predict_s` integrates) times a grade that holds
over a stretch of track: variance ``(a σ_γ)²``, correlation time ``L_γ / |v|``
(`GRADE_LENGTH_M` of track, capped at `MAX_CORRELATION_S`), as a density on the normal
row, ``(a σ_γ)² L_γ/|v|``: the information a white noise of that density gives over one
correlation time equals one look at the held grade (`railnav.filters.held_remainder`'s
rule for a held constant).

Measured (``tests/railnav/filters/test_grade_noise.py``): a trip simulated on a track
with 1.2 % grades, navigated on the same track made level with single-point fixes and a
tactical IMU, ended 3.8 m RMS along the track with 13 restarts and NEES 894 before; see
the test for what it is with both parts.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["UNKNOWN_GRADE_SIGMA_RAD", "GRADE_LENGTH_M", "MAX_CORRELATION_S",
           "unknown_grade_density"]

Array = npt.NDArray[np.float64]

#: σ of a grade the track does not know, rad: 20 ‰, so that ±2σ covers the steepest
#: main lines (35-40 ‰; most are within 12.5 ‰). Trams climb steeper (60-80 ‰): give
#: `NavigatorConfig.track_grade_sigma_rad` for them.
UNKNOWN_GRADE_SIGMA_RAD = 0.02
#: Track over which a grade holds, m: constant grades run between vertical curves over
#: hundreds of metres to kilometres; the longer, the less the rows can average it out.
GRADE_LENGTH_M = 1000.0
#: Longest correlation time taken (a train at a crawl), s.
MAX_CORRELATION_S = 600.0


def unknown_grade_density(accel_mps2: Array, speed_mps: float, sigma_grade_rad: float
                          ) -> Array:
    """Density of the term ``a γ`` on the pseudo-observation's normal row (module
    docstring), (m/s²)²·s.

    Parameters
    ----------
    accel_mps2 : ndarray, shape (M,)
        Along-track acceleration at each sample, m/s².
    speed_mps : float
        |speed| of the chunk's prior, m/s.
    sigma_grade_rad : float
        σ of the grade, rad.

    Returns
    -------
    ndarray, shape (M,)
        ``(a σ_γ)² · min(L_γ / |v|, MAX_CORRELATION_S)``.
    """
    correlation_s = MAX_CORRELATION_S if speed_mps * MAX_CORRELATION_S <= GRADE_LENGTH_M \
        else GRADE_LENGTH_M / speed_mps
    return (np.asarray(accel_mps2, dtype=float) * sigma_grade_rad) ** 2 * correlation_s
