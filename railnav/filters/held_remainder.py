r"""The share of the track linearization's remainder that a chunk holds, and its density.

A chunk's samples use the track linearized once, at the chunk start, along the path
predicted from the prior (`railnav.filters.constrained`): the curvature vector is expanded
to first order about each sample's reference ``s_ref``, and the part the expansion leaves
out, ``r = du/ds(s) − (du/ds)_lin − (d²u/ds²)_lin (s − s_ref)``, has the variance
``var = v⁴ E[(P⊥ r)²]`` over the prior of ``s`` (`railnav.filters.geometry_noise`). That
module gives it the correlation time ``T_c = 2 σ_s / |v|`` of a feature (a joint, a kink)
running through the prior's window, and the density ``var · T_c``.

**On an arc the remainder is not a passing feature.** There it is the truncation of the
expansion, ``v² (d³u/ds³) δ² / 2`` with ``δ = s − s_ref`` and ``d³u/ds³ = −κ² du/ds``
(a circle of curvature κ, in any plane): across the track ``v² κ³ δ² / 2``, 1.25e-3 m/s²
at 100 m/s on R 100 m and δ = 0.5 m (a quarter of one tactical accelerometer sample's
noise). ``δ`` is the truth's offset from the predicted path, which the chunk holds fixed:
the truncation is the same at every sample of the chunk and does not average down.
Averaged over a chunk of length ``T``, the accelerometer's white noise (density ``q``) has
the variance ``q / T`` on a row, while a constant of variance ``var_h`` keeps ``var_h``;
the white density with the same integral over the chunk is ``var_h · T``. Given only
``var_h · T_c``, the rows tell the chunk's mean residual to better than it is known, and
the filter explains the truncation with the wrong states (the entry of the 100-m circle at
100 m/s: ``2v − b_ay`` for a second, then, linearized afresh, ``(s, ψ)`` along the
direction the rows do not see: `docs/consistency-ablations.md`, stop 29).

`held_density` splits ``var`` accordingly. The held part is the arc's truncation over the
prior ``δ ~ N(0, σ_s²)`` (``E[δ⁴] = 3 σ_s⁴``),

``var_h = (3/4) v⁴ σ_s⁴ κ⁴ (P⊥ du/ds)²``   per row, at most ``var``,

held for the chunk's length ``T`` (the time from its prior to its last sample); the rest
is the passing part, with ``T_c`` as before:

``r_c = var · T_c + var_h · max(T − T_c, 0)``.

Where the curves are gentle (κ = 1/1000 m at 40 m/s and σ_s = 0.5 m: ``var_h`` ≈ 1e-13
(m/s²)², six orders below a tactical accelerometer's ``q``) nothing changes; at a joint
``var`` is the step's and ``var_h`` the arc's small truncation, so the step keeps its
``T_c``. The held part is not cut by shorter chunks (re-linearizing more often): that
was tried (stop 29) and made a restart on a ring worse, because a chunk cut after two
samples re-linearized at a posterior the first rows had made overconfident.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from strapdown.reduced import TRACK_PARAMETER_LAYOUT, cross_track_basis

__all__ = ["held_density", "held_variance"]

Array = npt.NDArray[np.float64]

_U = TRACK_PARAMETER_LAYOUT.slice("u_n")
_DU = TRACK_PARAMETER_LAYOUT.slice("du_ds_n")


def held_variance(params: Array, *, sigma_s_m: float, speed_mps: float) -> Array:
    """The arc truncation's variance per row over the prior of ``s`` (module docstring).

    Parameters
    ----------
    params : ndarray, shape (M, 16)
        Track parameters (`strapdown.reduced.TRACK_PARAMETER_NAMES`) at the samples.
    sigma_s_m : float
        Standard deviation of ``s``, m.
    speed_mps : float
        Speed, m/s.

    Returns
    -------
    ndarray, shape (M, 2)
        ``(3/4) v⁴ σ_s⁴ κ⁴ (l · du/ds)²`` and the same with the normal ``n``, (m/s²)², with
        ``κ = |du/ds|``.
    """
    du = params[:, _DU]
    lateral, normal = cross_track_basis(params[:, _U])
    kappa2 = np.einsum("mi,mi->m", du, du)
    across = np.stack([np.einsum("mi,mi->m", du, lateral),
                       np.einsum("mi,mi->m", du, normal)], axis=-1)
    return 0.75 * (speed_mps * sigma_s_m) ** 4 * (kappa2 ** 2)[:, None] * across ** 2


def held_density(variance: Array, params: Array, *, sigma_s_m: float, speed_mps: float,
                 correlation_s: float, held_s: float) -> Array:
    """Density of the geometry remainder on the rows: passing part and held part.

    Parameters
    ----------
    variance : ndarray, shape (M, 2)
        The remainder's variance per row, (m/s²)² (`geometry_noise.statistical_parameters`).
    params : ndarray, shape (M, 16)
        The samples' track parameters.
    sigma_s_m, speed_mps : float
        σ of ``s`` (m) and speed (m/s) of the chunk's prior.
    correlation_s : float
        ``T_c``, the passing part's correlation time, s
        (`geometry_noise.remainder_correlation_s`).
    held_s : float
        ``T``, how long the chunk holds its linearization: from its prior to its last
        sample, s.

    Returns
    -------
    ndarray, shape (M, 2)
        ``var · T_c + min(var_h, var) · max(T − T_c, 0)``, (m/s²)²·s.
    """
    r_c = variance * correlation_s
    extra = max(float(held_s) - float(correlation_s), 0.0)
    if extra > 0.0 and np.any(variance > 0.0):
        held = np.minimum(held_variance(params, sigma_s_m=sigma_s_m, speed_mps=speed_mps),
                          variance)
        r_c = r_c + held * extra
    return r_c
