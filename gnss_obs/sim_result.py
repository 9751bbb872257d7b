"""The output of a GNSS simulation (`gnss_obs.simulate.simulate_gnss`).

Kept apart from the generator so that the file writer (`gnss_obs.sim_files`) takes a
`GnssSimulation` without depending on the generator: ``simulate -> sim_files ->
sim_result`` and ``simulate -> sim_result``, one way.
"""
from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from gnss_obs.rinex_obs import RinexObs

__all__ = ["GnssSimulation"]


@dataclass(frozen=True, eq=False)
class GnssSimulation:
    """Output of `simulate_gnss`.

    Attributes
    ----------
    obs : RinexObs
        Header and observation table as `read_rinex_obs` returns them.
    clock : pandas.DataFrame
        Receiver clock truth: ``gps_time_s, clock_bias_m, clock_drift_mps``.
    satellites : pandas.DataFrame
        Per observation: ``gps_time_s, sv, elevation_deg, azimuth_deg, iono_m, tropo_m,
        multipath_m, fault_m, noise_pr_m, noise_rr_mps``, and the noise-free
        ``pseudorange_free_m`` and ``range_rate_free_mps`` (before rounding).
    """

    obs: RinexObs
    clock: pd.DataFrame
    satellites: pd.DataFrame
