"""Satellites at transmission: the Sagnac rotation, the batch of epochs."""
from __future__ import annotations

import numpy as np

from gnss_obs.constants import OMEGA_E_GPS, SPEED_OF_LIGHT_MPS, WEEK_S
from gnss_obs.epoch import split_epochs
from gnss_obs.measurements import MeasurementConfig, select_measurements
from gnss_obs.transmission import sagnac_rotation, transmit_states, transmit_states_batch

T_1240 = 2134 * WEEK_S + 45_600.0  # 2020-11-29 12:40:00 GPST


def test_sagnac_rotation_closed_form():
    """The Earth turns east by Ωτ during the flight: in the later frame a satellite on the
    x axis has y = -r sin(Ωτ) (its longitude decreased)."""
    tau = np.array([0.075])
    r, v = sagnac_rotation(np.array([[2.6e7, 0.0, 1.0]]), np.array([[0.0, 3.0e3, 0.0]]), tau)
    a = OMEGA_E_GPS * 0.075
    np.testing.assert_allclose(r[0], [2.6e7 * np.cos(a), -2.6e7 * np.sin(a), 1.0], rtol=1e-15)
    np.testing.assert_allclose(v[0], [3.0e3 * np.sin(a), 3.0e3 * np.cos(a), 0.0], rtol=1e-15)


def test_transmit_states_batch_equals_epoch_by_epoch(nav, rover_obs):
    """Reference: `transmit_states` called on each epoch on its own (GPS + Galileo, 20 s)."""
    cfg = MeasurementConfig(systems="GE")
    table = rover_obs.table[rover_obs.table["gps_time_s"] < T_1240 + 20]
    epochs = split_epochs(select_measurements(table, cfg), nav.records, cfg)
    batch = transmit_states_batch(epochs, cfg)
    assert len(batch) == len(epochs) == 20
    for epoch, (states, clock_m) in zip(epochs, batch):
        ref_states, ref_clock = transmit_states(epoch, cfg)
        np.testing.assert_array_equal(clock_m, ref_clock)
        np.testing.assert_array_equal(states.r_e, ref_states.r_e)
        np.testing.assert_array_equal(states.clock_drift_sps, ref_states.clock_drift_sps)


def test_transmit_states_batch_of_a_subset_or_modified_epochs(nav, rover_obs):
    """Epochs that are not one table cut whole (every other epoch; an epoch whose
    pseudoranges were replaced) take the stacking path: reference, `transmit_states` of
    each epoch on its own, and the replaced column is the one used."""
    cfg = MeasurementConfig(systems="GE")
    table = rover_obs.table[rover_obs.table["gps_time_s"] < T_1240 + 10]
    epochs = split_epochs(select_measurements(table, cfg), nav.records, cfg)
    every_other = epochs[::2]
    epochs[3].meas["pseudorange_m"] = epochs[3].meas["pseudorange_m"] + 1.0e4
    for subset in (every_other, epochs):
        batch = transmit_states_batch(subset, cfg)
        for epoch, (states, clock_m) in zip(subset, batch, strict=True):
            ref_states, ref_clock = transmit_states(epoch, cfg)
            np.testing.assert_array_equal(clock_m, ref_clock)
            np.testing.assert_array_equal(states.r_e, ref_states.r_e)
    moved = transmit_states(epochs[3], cfg)[0].r_e
    kept = transmit_states(split_epochs(select_measurements(table, cfg), nav.records,
                                        cfg)[3], cfg)[0]
    # transmitted 1e4 m / c = 33 µs earlier: the satellite is |v| · 33 µs (~0.1 m) back
    # (to 1 %: one satellite's broadcast-model velocity differs from its position's
    # 33-µs chord by 0.6 %; a stale column would move it by 0)
    np.testing.assert_allclose(np.linalg.norm(moved - kept.r_e, axis=1),
                               np.linalg.norm(kept.v_e, axis=1) * 1.0e4 / SPEED_OF_LIGHT_MPS,
                               rtol=1e-2)
