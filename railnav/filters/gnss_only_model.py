r"""The GNSS-only track-constrained filter's process model: along-track kinematics + clock.

State (`ekf.StateLayout`; names used everywhere, never indices)::

    [s, v, clock_bias, clock_drift, (isb_<system> ...)]      ([s, v] for position fixes only)

``s`` along-track distance (m), ``v = ds/dt`` signed speed (m/s: negative when the vehicle
runs towards the track start), receiver clock bias ``c δt_r`` (m) and drift (m/s), one
inter-system bias (m) per GNSS system after the first. There is no input and no
continuous measurement: between GNSS epochs the state only propagates::

    ṡ = v,   v̇ = w_a,   ḃ = d + w_b,   ḋ = w_d,   i̇sb = w_isb

``w_a`` is the along-track acceleration taken as white noise of spectral density
``σ_a²`` ((m/s²)²·s; `railnav.NavigatorConfig.along_accel_sigma_mps2`): the classic
"white-noise acceleration" (continuous Wiener velocity) model, whose exact discrete
process noise over a step ``Δt`` is ``σ_a² [[Δt³/3, Δt²/2], [Δt²/2, Δt]]`` (Bar-Shalom,
Li & Kirubarajan, *Estimation with Applications to Tracking and Navigation*, §6.2.2).
The clock is the two-state oscillator model of `gnss_obs.oscillator` (same form, its own
densities) and the inter-system biases are random walks of density
`railnav.filters.constrained_model.ISB_RANDOM_WALK_M2PS`.

With ``code_bias_time_s`` > 0 the state also carries ``code_bias`` (`CODE_BIAS_STATE`), the
slow part of the code errors along the track (`railnav.filters.code_bias`), dimensionless:
a first-order Gauss–Markov process of unit variance and correlation time τ_b,
``ḃ = −b/τ_b + w_b`` with ``q = 2/τ_b`` (its stationary variance ``q τ_b / 2 = 1``).

Why a velocity model and not a jerk model ``(s, v, a)`` (white jerk): trams and trains
change their acceleration within a second or two (traction notches, braking steps, stops),
so an acceleration state decorrelates before 1 Hz pseudoranges and Doppler can estimate
it. Measured once on the urban drive with an ``(s, v, a)`` variant (white jerk 0.3, 1 and
3 m/s³/√s, pseudorange correlation 20 s, not kept in the code): horizontal RMS 1.9–2.1 m
(GPS) and 1.10–1.12 m (GPS+Galileo), against 1.2 m and 1.4 m for this model with
σ_a = 1 m/s²: no consistent gain for a larger state.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.model import CdModel
from gnss_obs.oscillator import Oscillator
from railnav.filters.constrained_model import (
    CLOCK_STATE_NAMES,
    ISB_RANDOM_WALK_M2PS,
    isb_state_name,
)

__all__ = ["GnssOnlyModel", "build_gnss_only_model", "KINEMATIC_STATE_NAMES",
           "CODE_BIAS_STATE"]

Array = npt.NDArray[np.float64]

#: Kinematic states of the GNSS-only filter: along-track distance (m), speed (m/s).
KINEMATIC_STATE_NAMES = ("s", "v")
#: The slow along-track code error's state (`railnav.filters.code_bias`), dimensionless.
CODE_BIAS_STATE = "code_bias"


@dataclass(frozen=True, eq=False)
class GnssOnlyModel:
    """The GNSS-only filter's process model (module docstring).

    Attributes
    ----------
    process : ekf.CdModel
        ``f(x)``, ``G`` with empty ``u`` and ``p``.
    layout : ekf.StateLayout
    isb_systems : tuple of str
        Systems with an inter-system bias state.
    noise_names : tuple of str
        Components of ``w``: ``w_a, w_clock_bias, w_clock_drift, w_isb_<system>...``
        (``w_code_bias`` with the code-bias state), then the extra states'.
    code_bias_time_s : float
        τ_b of the code-bias state, s (0: no such state).
    """

    process: CdModel
    layout: StateLayout
    isb_systems: tuple[str, ...]
    noise_names: tuple[str, ...]
    extra_names: tuple[str, ...] = ()
    code_bias_time_s: float = 0.0

    def process_noise_density(self, *, along_accel_sigma_mps2: float,
                              oscillator: Oscillator, extra_q: tuple[float, ...] = ()) -> Array:
        """Diagonal spectral density ``q_c`` of ``w``.

        Parameters
        ----------
        along_accel_sigma_mps2 : float
            σ_a: the along-track acceleration white-noise density is ``σ_a²``
            ((m/s²)²·s).
        oscillator : gnss_obs.oscillator.Oscillator
            The receiver clock the filter assumes.
        extra_q : tuple of float
            Densities of the extra random-walk states (`extra_names`), in order.

        Returns
        -------
        ndarray, shape (n_w,)
            ``[(m/s²)²·s, m²/s, m²/s³, m²/s ..., (1/s), extra ...]``.
        """
        if len(extra_q) != len(self.extra_names):
            raise ValueError(f"{len(self.extra_names)} extra states, {len(extra_q)} densities")
        q = [along_accel_sigma_mps2 ** 2]
        if "clock_bias" in self.layout.names:
            q += [oscillator.q_bias_m2ps, oscillator.q_drift_m2ps3]
        q += [ISB_RANDOM_WALK_M2PS] * len(self.isb_systems)
        if self.code_bias_time_s > 0.0:          # unit stationary variance
            q.append(2.0 / self.code_bias_time_s)
        q += [max(float(v), 1e-30) for v in extra_q]      # kept > 0: P stays definite
        return np.array(q, dtype=float)


@functools.lru_cache(maxsize=None)
def build_gnss_only_model(isb_systems: tuple[str, ...] = (), *,
                          clock: bool = True, extra_blocks: tuple = (),
                          code_bias_time_s: float = 0.0) -> GnssOnlyModel:
    """Build (once per argument) the GNSS-only process model.

    Parameters
    ----------
    isb_systems : tuple of str
        GNSS systems that get an inter-system bias state (e.g. ``("E",)``).
    clock : bool
        With the receiver clock states; without (position fixes only, no pseudorange) the
        state is ``[s, v]`` and the noise ``w_a`` alone.
    extra_blocks : tuple of (str, tuple of str)
        Further random-walk states, appended last (`railnav.filters.sensor_rows`).
    code_bias_time_s : float
        τ_b of the code-bias state (module docstring), s; 0: no such state.

    Returns
    -------
    GnssOnlyModel
    """
    if not clock and isb_systems:
        raise ValueError("inter-system biases need the clock states")
    blocks = [("s", 1), ("v", 1)] + ([("clock", CLOCK_STATE_NAMES)] if clock else [])
    if isb_systems:
        blocks.append(("isb", tuple(isb_state_name(s) for s in isb_systems)))
    bias = code_bias_time_s > 0.0
    if bias:
        blocks.append((CODE_BIAS_STATE, 1))
    blocks += list(extra_blocks)
    extra_names = tuple(n for _, names in extra_blocks for n in names)
    layout = StateLayout.from_blocks(blocks)
    x = ca.SX.sym("x", layout.size)
    u = ca.SX.sym("u", 0, 1)
    p = ca.SX.sym("p", 0, 1)
    clock_dot = [x[layout.index("clock_drift")], 0.0] if clock else []
    bias_dot = [-x[layout.index(CODE_BIAS_STATE)] / code_bias_time_s] if bias else []
    xdot = ca.vertcat(x[layout.index("v")], 0.0, *clock_dot, ca.SX.zeros(len(isb_systems)),
                      *bias_dot, ca.SX.zeros(len(extra_names)))
    driven = [layout.index("v")] + ([layout.index("clock_bias"), layout.index("clock_drift")]
                                    if clock else []) + \
        [layout.index(isb_state_name(s)) for s in isb_systems] + \
        ([layout.index(CODE_BIAS_STATE)] if bias else []) + \
        [layout.index(n) for n in extra_names]
    G = ca.SX.zeros(layout.size, len(driven))
    for col, row in enumerate(driven):
        G[row, col] = 1.0
    name = "railnav_gnss_only" + ("_isb" + "".join(isb_systems) if isb_systems else "") + \
        ("" if clock else "_noclock") + \
        (f"_codebias{code_bias_time_s:g}".replace(".", "p") if bias else "") + \
        "".join(f"_{n}" for n in extra_names)
    process = CdModel.from_expressions(layout, x, u, p, xdot, G=G, name=name)
    noise_names = ("w_a",) + tuple(f"w_{layout.names[i]}" for i in driven[1:])
    return GnssOnlyModel(process=process, layout=layout, isb_systems=tuple(isb_systems),
                         noise_names=noise_names, extra_names=extra_names,
                         code_bias_time_s=float(code_bias_time_s) if bias else 0.0)
