"""Satellites at the transmission instant: positions, velocities and clocks of the signals.

What each epoch's measurements say about the satellites before any receiver guess
(`gnss_obs.epoch.prepare_epoch` adds what depends on the guess):

* **transmission time** from the measured pseudorange (RTKLIB's method):
  ``t_tx = t_rx - P/c - δt_sv(t_tx)``. Since ``P = c(τ + δt_r - δt_sv)`` and the time tag is
  receiver time, this is the true transmission time whatever the receiver clock bias,
  up to the atmosphere delays (tens of ns: sub-millimetre in the satellite position);
* **satellite clock** for the signal used: broadcast clock with the relativistic term minus
  the group delay of the signal (or of the ionosphere-free pair), in metres; orbits and
  clocks from precise products instead with `gnss_obs.precise.PreciseOrbits`;
* **Earth rotation during the flight** (Sagnac, `sagnac_rotation`): the satellite position
  and velocity at ``t_tx`` are turned by ``R_z(Ω τ)`` into the ECEF frame of the reception
  instant, ``τ = |r_sat - r_rx| / c`` from the receiver position guess (ARCHITECTURE.md,
  GNSS; ``Ω = OMEGA_E_GPS`` for every system); `gnss_obs.epoch` applies it at each guess.

`transmit_states_batch` evaluates the states of many epochs at once (a filter's whole file).
"""
from __future__ import annotations

from dataclasses import fields

import numpy as np
import numpy.typing as npt

from gnss_obs.constants import OMEGA_E_GPS, SPEED_OF_LIGHT_MPS
from gnss_obs.ephemeris import group_delay_s, satellite_states
from gnss_obs.epoch_table import EpochData, whole_table
from gnss_obs.measurements import MeasurementConfig

__all__ = ["sagnac_rotation", "sagnac_cos_sin", "sagnac_turn", "transmit_states",
           "transmit_states_batch"]

Array = npt.NDArray[np.float64]


def sagnac_rotation(r_sat_e: Array, v_sat_e: Array, tau_s: Array) -> tuple[Array, Array]:
    """Turn satellite states at transmission into ECEF of the reception instant.

    Parameters
    ----------
    r_sat_e, v_sat_e : ndarray, shape (N, 3)
        Position (m) and velocity (m/s) in ECEF at the transmission instant.
    tau_s : ndarray, shape (N,)
        Signal flight time, s.

    Returns
    -------
    r, v : ndarray, shape (N, 3)
        ``R_z(Ω τ) r`` and ``R_z(Ω τ) v`` with ``Ω = OMEGA_E_GPS``: the Earth turns by
        ``Ω τ`` during the flight, so in the later frame the satellite's longitude is
        smaller by that angle.
    """
    c, s = sagnac_cos_sin(tau_s)
    both = np.array([r_sat_e, v_sat_e])           # (2, N, 3): one pass for both
    out = np.empty_like(both)
    out[..., 0], out[..., 1] = sagnac_turn(c, s, both[..., 0], both[..., 1])
    out[..., 2] = both[..., 2]
    return out[0], out[1]


def sagnac_cos_sin(tau_s):
    """``cos(Ω τ), sin(Ω τ)`` of `sagnac_rotation` (NumPy ufuncs: also CasADi symbols)."""
    a = OMEGA_E_GPS * tau_s
    return np.cos(a), np.sin(a)


def sagnac_turn(c, s, x, y):
    """The x and y components of ``R_z(Ω τ) (x, y, z)`` from `sagnac_cos_sin` (operators
    only: also CasADi symbols)."""
    return c * x + s * y, -s * x + c * y


def _signal_group_delay_s(eph: dict, meas: dict, config: MeasurementConfig) -> Array:
    g1 = group_delay_s(eph, meas["band"], galileo_message=config.galileo_message)
    if not config.iono_free:
        return g1
    g2 = group_delay_s(eph, meas["band2"], galileo_message=config.galileo_message)
    f1, f2 = meas["frequency_hz"] ** 2, meas["frequency2_hz"] ** 2
    return (f1 * g1 - f2 * g2) / (f1 - f2)


def _states(eph, meas, t, precise):
    if precise is None:
        return satellite_states(eph, t)
    return precise.states(meas["sv"], t)


def transmit_states(epoch: EpochData, config: MeasurementConfig, *, precise=None):
    """Satellite states at the transmission instants (ECEF of transmission) and clocks (m).

    With `precise` (a `gnss_obs.precise.PreciseOrbits`), orbits and clocks come from it
    instead of the broadcast ephemeris; the broadcast group delays still apply.
    """
    meas, eph = epoch.meas, epoch.eph
    t_nominal = epoch.gps_time_s - meas["pseudorange_m"] / SPEED_OF_LIGHT_MPS
    # δt_sv varies by ~1e-11 s/s: evaluated at t_nominal (ms away) it is exact to 1e-14 s.
    t_tx = t_nominal - _states(eph, meas, t_nominal, precise).clock_s
    states = _states(eph, meas, t_tx, precise)
    clock_m = SPEED_OF_LIGHT_MPS * (states.clock_s - _signal_group_delay_s(eph, meas, config))
    return states, clock_m


def transmit_states_batch(epochs: list[EpochData], config: MeasurementConfig, *,
                          precise=None) -> list:
    """`transmit_states` of many epochs in one vectorized evaluation (`precise` as there).

    The transmission-time states do not depend on the receiver guess, so a filter can
    compute them for a whole file at once and pass each epoch's to
    `gnss_obs.epoch.prepare_epoch`.

    Returns
    -------
    list of (SatelliteStates, ndarray)
        One ``(states, clock_m)`` per epoch, equal to ``transmit_states(epoch, config)``.
    """
    if not epochs:
        return []
    sizes = np.array([len(e) for e in epochs])
    whole = whole_table(epochs)
    if whole is not None:    # `split_epochs` of one table: its columns as they are
        meas, eph = whole
        times = meas["gps_time_s"]       # each row's time is its epoch's
    else:
        meas = {k: np.concatenate([e.meas[k] for e in epochs]) for k in epochs[0].meas}
        eph = {k: np.concatenate([e.eph[k] for e in epochs]) for k in epochs[0].eph}
        times = np.repeat([e.gps_time_s for e in epochs], sizes)
    states, clock_m = transmit_states(EpochData(times, meas, eph), config, precise=precise)
    bounds = np.concatenate([[0], np.cumsum(sizes)]).tolist()
    names = [f.name for f in fields(states)]
    columns = [getattr(states, name) for name in names]
    kind = type(states)
    return [(kind(**{name: column[a:b] for name, column in zip(names, columns)}), clock_m[a:b])
            for a, b in zip(bounds[:-1], bounds[1:])]
