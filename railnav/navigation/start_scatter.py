r"""How honest a GNSS start's σ is: the scatter of the first fixes about a smooth path
(issue 14, "never confidently wrong").

A filter started from files begins at the first single-point fix
(`railnav.navigation.initialization.first_fix`), with that fix's covariance from the σ the
receiver is assumed to have (``gnss_obs.MeasurementConfig``). When those σ are too small,
the filter starts overconfident, and the adaptive noise scale
(`railnav.filters.noise_scale`) needs epochs of evidence before it rises. A 300-s
simulated curvy trip run as plain files (the simulator's σ √15 m and √0.5 m/s at every
elevation, the real receiver's 1 m and 0.05 m/s at zenith assumed) started 1.0 m/s off at
σ_v 0.065 m/s, and was 13.8 m off at z 5.3 20 s later.

**Why the fix's own χ² does not see it.** That SPP's χ²/dof over the first 60 epochs was
1.7 (pseudorange) and 3.2 (Doppler), while its along-track errors had RMS z 2.65 and 8.5
(variance factors 7 and 72). The σ model's *shape* is wrong (σ/sin(el) with a C/N0
penalty against a constant σ): the high satellites are overconfident, the low ones
pessimistic. The high satellites carry the solution (leverage near 1), so their
residuals are small whatever their error: a post-fit residual's variance is
``Σ_j M_ij² λ_j / M_ii`` (``M = I − P``, the whitened residual projector, ``λ_j`` each
row's true/told variance ratio), a row's own ``λ_i`` weighted by ``M_ii = 1 − h_ii``
only. With 7 satellites and 4 unknowns (dof 3), the χ² is the low satellites' story; the
fix's error is the high satellites'. Its expectation from each row's ratio (simulated
√15 m and √0.5 m/s over the told σ) and leverage, ``Σ_i M_ii λ_i / dof``, is 2.55 and 31
on those epochs; the observed 1.7 and 3.2 are lower still because the χ² reported is the
one after RAIM/FDE, which excludes rows until it passes (the Doppler χ² was below its
1e-3 threshold at all 60 epochs, 0.99 of it at most; a satellite excluded at about half
of them, dof 2).

**What does see it: the fixes' scatter.** The errors of successive fixes are what the fix
covariance promises, whatever the rows' shape. `scatter_factors` fits the horizontal
(east, north) positions of the first `START_EPOCHS` fixes with a cubic in time and their
velocities with a quadratic (a train's motion over 10 s), whitened by each fix's own
horizontal covariance (the velocities of a moving start by their speed alone, with its σ
along the velocity: a turn rotates the components, not the speed; a car in the urban
drive's corners had them off a quadratic by up to 80× their variance), and tests each
fit's χ² at `P_FALSE_INFLATION`: significant, the
variance factor is ``χ²/dof``; not, exactly 1 (a start told the right σ is unchanged, to
the bit, but in `P_FALSE_INFLATION` of the starts or where the motion is not smooth over
the window). The factor multiplies the fix's covariance (`inflated_fix`). Errors slower
than the window (multipath, ionosphere) are not seen: the scatter gives a floor on the
overconfidence, not the whole of it.

**Measured** (s39start; the factors also seed the noise scale, `NoiseScale.seed`): the
300-s plain curvy trip (seed 0) got ×14.4 / ×36.9, NEES 23.3 -> 1.89, along-track max
15.1 -> 3.3 m, NEES in its first 10 s 175 -> 1.8; ten seeds, NEES at 5 s 64 -> 3.3;
paper2017 plain files (moving at 20 m/s), five seeds, NEES 15.1 -> 1.23, lost epochs
100 -> 0. Told the σ (``scenario.json``), 8 of 8 runs bit-identical. On the urban drive's
pieces (gnss-only) the position factor was 1 on every piece (its errors are slow) and
the velocity factor 3.4-71; epochs beyond 3σ_s left ``ok`` 35 -> 23 (leg 1 whole
20 -> 20, the other pieces 15 -> 3), and a start inside the U-turn (46006) 13 -> 0.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.special import chdtri

from trackmodel.earth import C_n_e, ecef_to_geodetic

__all__ = ["START_EPOCHS", "P_FALSE_INFLATION", "ScatterFactors", "scatter_factors",
           "polynomial_chi2"]

Array = npt.NDArray[np.float64]

#: Fixes whose scatter is tested (the first fix and those after it).
START_EPOCHS = 10
#: Probability that a start told the right σ (and moving smoothly) is inflated.
P_FALSE_INFLATION = 1e-3
#: Polynomial degrees in time of the positions and of the velocities.
POSITION_DEGREE, VELOCITY_DEGREE = 3, 2
#: A start moves when every fix's speed is beyond this many σ (`scatter_factors`).
MOVING_SIGMAS = 5.0
#: Time unit of the polynomials, s (conditioning only).
_TIME_UNIT_S = 10.0


@dataclass(frozen=True)
class ScatterFactors:
    """Variance factors of a start's position and velocity (1: not significant).

    Attributes
    ----------
    position, velocity : float
        ``χ²/dof`` of the fits when significant, else 1.
    chi2_position, chi2_velocity : float
    dof_position, dof_velocity : int
        0 (and factor 1) with too few fixes.
    """

    position: float
    velocity: float
    chi2_position: float = 0.0
    dof_position: int = 0
    chi2_velocity: float = 0.0
    dof_velocity: int = 0


def polynomial_chi2(time_s: Array, values: Array, cov: Array, *, degree: int
                    ) -> tuple[float, int]:
    """χ² and dof of a fit of a polynomial in time to each component of `values`.

    Parameters
    ----------
    time_s : ndarray, shape (N,)
    values : ndarray, shape (N, d)
    cov : ndarray, shape (N, d, d)
        Each epoch's covariance of `values` (the epochs independent).
    degree : int

    Returns
    -------
    chi2 : float
        ``min Σ_k r_kᵀ cov_k⁻¹ r_k`` over the ``d (degree + 1)`` coefficients.
    dof : int
        ``d (N − degree − 1)`` (0: no test; chi2 0).
    """
    n, d = values.shape
    dof = d * (n - degree - 1)
    if dof <= 0:
        return 0.0, 0
    basis = np.vander((time_s - time_s[0]) / _TIME_UNIT_S, degree + 1, increasing=True)
    L_inv = np.linalg.inv(np.linalg.cholesky(cov))                       # (N, d, d)
    design = np.einsum("kij,kp->kipj", L_inv, basis).reshape(n * d, d * (degree + 1))
    y = np.einsum("kij,kj->ki", L_inv, values).reshape(n * d)
    coef = np.linalg.lstsq(design, y, rcond=None)[0]
    return float(np.sum(np.square(y - design @ coef))), dof


def _velocity_chi2(time_s: Array, v_h: Array, cov_v_h: Array) -> tuple[float, int]:
    """The velocity fit's χ² and dof: of the horizontal speed, with its variance along the
    velocity, when every fix moves by more than `MOVING_SIGMAS` of it (a turn rotates the
    components, not the speed), else of the east and north components. The σ of that
    test are the components' own times their fit's ``χ²/dof`` when above 1: overconfident
    velocities of a standing receiver look like motion by their σ alone."""
    chi_c, dof_c = polynomial_chi2(time_s, v_h, cov_v_h, degree=VELOCITY_DEGREE)
    speed = np.linalg.norm(v_h, axis=1)
    u = v_h / np.where(speed > 0.0, speed, 1.0)[:, None]
    var = np.einsum("ki,kij,kj->k", u, cov_v_h, u)
    scatter = max(chi_c / dof_c, 1.0) if dof_c > 0 else 1.0
    if np.all(speed > MOVING_SIGMAS * np.sqrt(var * scatter)):
        return polynomial_chi2(time_s, speed[:, None], var[:, None, None],
                               degree=VELOCITY_DEGREE)
    return chi_c, dof_c


def _factor(chi2_value: float, dof: int, p_false: float) -> float:
    if dof <= 0 or chi2_value <= chdtri(dof, p_false):
        return 1.0
    return chi2_value / dof


def scatter_factors(time_s: Array, r_e: Array, v_e: Array, cov_enu_m2: Array,
                    cov_v_enu_m2ps2: Array, *, p_false: float = P_FALSE_INFLATION
                    ) -> ScatterFactors:
    """The variance factors of the first fix's position and velocity covariances, from the
    scatter of fixes about a smooth path (module docstring).

    Parameters
    ----------
    time_s : ndarray, shape (N,)
        The fixes' times (increasing), the first the start's.
    r_e, v_e : ndarray, shape (N, 3)
        ECEF position and velocity (finite).
    cov_enu_m2, cov_v_enu_m2ps2 : ndarray, shape (N, 3, 3)
        Their covariances in ENU.
    p_false : float
        Probability of a factor above 1 when the covariances are right.

    Returns
    -------
    ScatterFactors
    """
    lat, lon, _ = ecef_to_geodetic(r_e[0])
    C = C_n_e(lat, lon)                                        # ENU -> ECEF at the start
    enu = (r_e - r_e[0]) @ C                                   # rows: Cᵀ (r - r0)
    v_enu = v_e @ C
    horizontal = slice(0, 2)
    chi_p, dof_p = polynomial_chi2(time_s, enu[:, horizontal],
                                   cov_enu_m2[:, horizontal, horizontal],
                                   degree=POSITION_DEGREE)
    chi_v, dof_v = _velocity_chi2(time_s, v_enu[:, horizontal],
                                  cov_v_enu_m2ps2[:, horizontal, horizontal])
    return ScatterFactors(_factor(chi_p, dof_p, p_false), _factor(chi_v, dof_v, p_false),
                          chi_p, dof_p, chi_v, dof_v)
