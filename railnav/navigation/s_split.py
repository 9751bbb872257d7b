r"""The Gaussian sum along ``s``: a hypothesis whose σ_s has grown against the track's
curvature features is split into components, each a filter of its own.

One Gaussian along the track is a poor description of where the train is once σ_s spans
curvature features (which curve was that?): the filter linearizes the pseudo-observation
at one ``s``, follows the curve it thinks it is in, and can lock onto the wrong one with
a shrinking σ. `needs_split` says when: σ_s above `NetworkNavConfig.split_sigma_m` and
what the track would put on the accelerometer spreading by more than
`NetworkNavConfig.split_accel_mps2` over ``s' ∈ s ± (3σ_s + |v|·1 s)`` (before the next
cycle reaches the feature, not after): the lateral acceleration
``v² κ(s')``, the vertical ``v² dϑ/ds(s')``, or the along-track share of gravity on the
grade, ``g sin ϑ(s')``. `split` replaces the Gaussian by three components,
`SPLIT_WEIGHTS` at `SPLIT_OFFSETS` σ_s apart, each with σ_s scaled by `SPLIT_SIGMA_FACTOR`
``f``. The other states follow their regression on ``s``: component i has
``x + P[:, s] δ_i / P[s, s]`` and ``P − (1 − f²) P[:, s] P[s, :] / P[s, s]`` (the
conditional Gaussian), so speed, attitude and biases stay as correlated with ``s`` as they
were, and the mixture keeps the parent's mean and covariance exactly.

**Why these weights: the split is repeated, and its tails compound.** A component whose
σ_s is still above the threshold splits again in the next cycle, so near a curve the
parent becomes ``3ⁿ`` components after n generations: a sum ``Σ_k m f^k ε_k`` (ε_k ∈
{−1, 0, +1}) plus a Gaussian of σ ``fⁿ``. Its reach is ``± m/(1 − f)`` σ of the parent,
and its tails are the Gaussian's only if each split keeps the fourth moment: with
``2 w m² + f² = 1`` (the variance), the fourth moment is ``3`` exactly when ``w = 1/6``
(the three-point Gauss–Hermite weights), whatever ``f``. Huber et al.'s (2008)
``w = 0.2252`` at ``m = 1.0575`` (their split of a unit Gaussian, chosen for one split)
is platykurtic (fourth moment 2.80); after four generations (81 components) the mixture's
mass below ``−3σ`` is 3.0e-4 and below ``−3.3σ`` 1.9e-5, against the Gaussian's 1.35e-3
and 4.8e-4 (26× thinner), and nothing is left beyond 3.58σ. A truth 3.3σ off (the
tactical 20-min outage of ``curvy``, seed 5, 300 s into the outage: the constrained
filter's pitch/``b_ax`` error at a braking) then falls out of the mixture as it nears a
curve, the components pile up at the curve's start with their σ collapsing, and the
survivor is reported with P = 1 at 44σ (`benchmarks/bench_network_outage.py`). Here
``w = 1/6``, ``f`` kept at Huber's 0.7044 (the children are as narrow as before, so the
splits come as often) and ``m = √(3(1 − f²)) = 1.2293``: after four generations the
mass below ``−3σ`` is 9.9e-4 and below ``−3.3σ`` 2.2e-4 (the Gaussian's to 0.74× and
0.46×), the reach 4.16σ; the sixth moment, which three components cannot keep, is
``15 − 6(1 − f²)³`` = 14.2 against 15.

The components are hypotheses like the others (`railnav.navigation.hypotheses`): each
linearizes its own pseudo-observation; the weights take the common-covariance evidence of
`railnav.navigation.hypothesis_step` (the lateral acceleration the vehicle felt against
the curvature each component expected) and GNSS when it is back; components that come
together merge (GPB1) and improbable ones are pruned; each splits again if its own σ_s
grows so.
"""
from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from railnav.navigation.hypotheses import CYCLE_REACH_S, hypothesis

__all__ = ["needs_split", "split", "SPLIT_WEIGHTS", "SPLIT_OFFSETS", "SPLIT_SIGMA_FACTOR",
           "SPLIT_PROBES", "GRAVITY_MPS2"]

Array = npt.NDArray[np.float64]

#: σ of each component in σ of the original (Huber et al. 2008's, module docstring).
SPLIT_SIGMA_FACTOR = 0.7044466327
#: Weights of the components: the three-point Gauss–Hermite weights, so that every split
#: keeps the fourth moment of the Gaussian (module docstring).
SPLIT_WEIGHTS = (1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0)
#: Offsets of the components, in σ of the original: the rest of the unit variance.
_OFFSET = math.sqrt(3.0 * (1.0 - SPLIT_SIGMA_FACTOR ** 2))
SPLIT_OFFSETS = (-_OFFSET, 0.0, _OFFSET)
#: Points of the track sampled over ±3σ_s to see its curvature features.
SPLIT_PROBES = 41
#: |g| for the along-track share of gravity on a grade, m/s² (a feature test: 0.3 %).
GRAVITY_MPS2 = 9.81


def needs_split(h, nav) -> bool:
    """Whether hypothesis `h`'s σ_s spans curvature features (module docstring)."""
    i_s, i_v = h.index("s"), h.index("v")
    sigma = math.sqrt(max(float(h.P[i_s, i_s]), 0.0))
    if sigma <= nav.split_sigma_m:
        return False
    track = h.filt.track
    reach = 3.0 * sigma + abs(float(h.x[i_v])) * CYCLE_REACH_S   # the next cycle too
    s = np.clip(h.s_m + reach * np.linspace(-1.0, 1.0, SPLIT_PROBES), 0.0, track.length_m)
    p = track.at(s)
    v2 = float(h.x[i_v]) ** 2
    spread = max(v2 * float(np.ptp(p.curvature_1pm)), v2 * float(np.ptp(p.elevation_rate)),
                 GRAVITY_MPS2 * float(np.ptp(np.sin(p.elevation))))
    return spread > nav.split_accel_mps2


def split(h, tracks, make_child) -> list:
    """The components of `h` (module docstring), each with a filter of its own
    (``make_child(parent, pieces)``)."""
    i_s = h.index("s")
    column = h.P[:, i_s]
    var_s = float(h.P[i_s, i_s])
    sigma = math.sqrt(var_s)
    gain = column / var_s
    P = h.P - (1.0 - SPLIT_SIGMA_FACTOR ** 2) * np.outer(column, column) / var_s
    out = []
    for w, m in zip(SPLIT_WEIGHTS, SPLIT_OFFSETS):
        x = h.x + gain * (m * sigma)
        out.append(hypothesis(tracks, h.pieces, x, P.copy(), h.log_weight + math.log(w),
                              make_child(h, h.pieces), h.path, h.id, fix_bias=h.fix_bias,
                              end_watch=h.end_watch.shifted(m * sigma)))
    return out
