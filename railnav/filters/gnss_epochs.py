"""GNSS epochs for a filter: selection, outage windows, per-epoch preparation at a guess.

The filters consume GNSS data through `GnssEpochs`: the observation file cut into epochs
once (`gnss_obs.epoch.split_epochs`: signal choice and ephemeris selection for the whole
file), restricted to the trip and to the outside of the user's outage windows, with each
epoch's time relative to the trip start. `GnssEpochs.prepare` then gives the satellites of
one epoch at the filter's current position guess (transmission-time states, Sagnac,
satellite clocks, atmosphere, σ), above the elevation mask and with finite measurements:
what does not depend on the guess computed for all epochs at once, what does in compiled
C (`railnav.filters.guess_kernel`).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from gnss_obs.coverage import check_nav_coverage
from gnss_obs.dgps import apply_corrections
from gnss_obs.epoch import (
    EpochData,
    PreparedEpoch,
    prepare_epochs,
    split_epochs,
)
from gnss_obs.guess_terms import satellite_columns_batch
from gnss_obs.measurements import (
    MeasurementConfig,
    glonass_channels,
    select_measurements,
)
from gnss_obs.rinex_nav import RinexNav
from gnss_obs.rinex_obs import RinexObs
from gnss_obs.sim_events import in_outages
from gnss_obs.transmission import transmit_states_batch
from railnav.filters.guess_kernel import compiled_evaluator

__all__ = ["GnssEpochs"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class GnssEpochs:
    """The usable GNSS epochs of a trip.

    Attributes
    ----------
    epochs : list of gnss_obs.EpochData
        In time order.
    time_s : ndarray, shape (E,)
        Epoch times from the trip start, s.
    config : gnss_obs.MeasurementConfig
    elevation_mask_rad : float
    klobuchar : (alpha, beta) or None
        Broadcast ionosphere coefficients of the navigation file.
    transmit : list
        Satellite states at transmission of each epoch (`gnss_obs.transmit_states_batch`:
        they do not depend on the receiver guess, so they are computed once).
    columns : list of ndarray, optional
        The satellites' columns of each epoch (`gnss_obs.guess_terms.satellite_columns`,
        for all epochs at once; made by `prepare_together` when not given).
    evaluate : callable, optional
        The satellite terms at a guess in compiled C
        (`railnav.filters.guess_kernel.compiled_evaluator`; None: in NumPy).
    """

    epochs: list[EpochData]
    time_s: Array
    config: MeasurementConfig
    elevation_mask_rad: float
    klobuchar: tuple[Array, Array] | None
    transmit: list
    columns: list | None = None
    evaluate: object = None

    @classmethod
    def from_files(cls, obs: RinexObs, nav: RinexNav, config: MeasurementConfig, *,
                   start_gps_time_s: float, end_s: float, outages=(),
                   elevation_mask_deg: float = 10.0, augmentation=None) -> "GnssEpochs":
        """Select the epochs of ``[0, end_s]`` outside the outages.

        Parameters
        ----------
        obs, nav : RinexObs, RinexNav
        config : gnss_obs.MeasurementConfig
        start_gps_time_s : float
            GPS time of the trip start (``time_s = 0``), s.
        end_s : float
            Last usable time from the trip start, s.
        outages : sequence of gnss_obs.Outage (or (start_s, duration_s) pairs)
            Windows whose epochs are dropped.
        elevation_mask_deg : float
        augmentation : gnss_obs.Augmentation, optional
            Base corrections (code-differential rows: uncorrected satellites are left
            out) and precise orbits (`gnss_obs.augment`).
        """
        table = obs.table
        t_rel = table["gps_time_s"].to_numpy() - start_gps_time_s
        keep = (t_rel >= -1e-9) & (t_rel <= end_s + 1e-9) & ~in_outages(t_rel, outages)
        table = table[keep]
        channels = glonass_channels(obs.header.glonass_slots, nav.records) \
            if "R" in config.systems else None
        meas = select_measurements(table, config, glonass_channels=channels)
        check_nav_coverage(obs, nav, config.systems, table=table)
        precise = None
        if augmentation is not None:
            precise = augmentation.precise
            if augmentation.corrections is not None:
                meas = apply_corrections(meas, augmentation.corrections,
                                         max_age_s=augmentation.max_age_s)
        epochs = split_epochs(meas, nav.records, config) if len(meas) else []
        alpha, beta = nav.header.iono_gps_alpha, nav.header.iono_gps_beta
        klobuchar = None if alpha is None or beta is None else (alpha, beta)
        times = np.array([e.gps_time_s - start_gps_time_s for e in epochs], dtype=float)
        transmit = transmit_states_batch(epochs, config, precise=precise)
        return cls(epochs=epochs, time_s=times, config=config,
                   elevation_mask_rad=float(np.deg2rad(elevation_mask_deg)), klobuchar=klobuchar,
                   transmit=transmit,
                   columns=satellite_columns_batch(epochs, transmit, config),
                   evaluate=compiled_evaluator(config))

    def __len__(self) -> int:
        return len(self.epochs)

    def prepare(self, index: int, r_guess_e: Array) -> PreparedEpoch:
        """Satellites of epoch `index` usable at the receiver guess (ECEF, m, shape (3,))."""
        return self.prepare_together(index, r_guess_e)[0]

    def prepare_together(self, index: int, r_guess_e: Array) -> list[PreparedEpoch]:
        """`prepare` at K receiver guesses (ECEF, m, shape (K, 3); a bank's hypotheses; or
        one, shape (3,)): `gnss_obs.epoch.prepare_epochs`, each guess's satellites those of
        its own `prepare`."""
        transmit = self.transmit[index] if self.columns is None else \
            (*self.transmit[index], self.columns[index])
        return prepare_epochs(self.epochs[index], self.config, r_rx_e=r_guess_e,
                              klobuchar=self.klobuchar, transmit=transmit,
                              elevation_mask_rad=self.elevation_mask_rad,
                              evaluate=self.evaluate)
