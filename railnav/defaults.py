"""The defaults of a run that the command line shows: each written once here.

`DEFAULT_FILTER`, `DEFAULT_IMU_GRADE`, `DEFAULT_SYSTEMS` (the defaults of
`railnav.config.NavigatorConfig`, which re-exports them; `DEFAULT_SYSTEMS` is also
`railnav.spp_files`'s), `default_filter` (the filter of sensor files without one named:
`railnav.run_files` and its kin, ``railnav run``), `DEFAULT_SEED` (of every simulated
trip), `DEFAULT_IONOSPHERE` and `DEFAULT_ELEVATION_MASK_DEG` (of `railnav.spp_files`),
`DEFAULT_CROSSING_RATE_PER_S` (of `railnav.navigation.network_config.NetworkNavConfig`;
`railnav.navigation.bank` explains it), `DEFAULT_HORIZON_M` and
`DEFAULT_NETWORK_SPEED_MPS` (track networks). They live in a module that imports nothing,
so that the ``railnav`` parser (help texts, choices, defaults) is built without importing
the engine, CasADi, SciPy or pandas: ``railnav --help`` and an argument error stay fast.
The other defaults of a simulated trip (speed profile, GNSS σ, start time) are its
scenario's (`railnav.simulation.scenarios`).
"""
from __future__ import annotations

__all__ = ["DEFAULT_FILTER", "DEFAULT_IMU_GRADE", "DEFAULT_SYSTEMS",
           "DEFAULT_CROSSING_RATE_PER_S", "DEFAULT_HORIZON_M", "DEFAULT_ODOMETER_SIGMA_MPS",
           "DEFAULT_BALISE_SIGMA_M", "DEFAULT_IONOSPHERE", "DEFAULT_ELEVATION_MASK_DEG",
           "DEFAULT_SEED", "DEFAULT_NETWORK_SPEED_MPS", "default_filter"]

#: The filter a run uses when none is named (`railnav.filters.protocol.FILTERS`).
DEFAULT_FILTER = "constrained"
#: The IMU grade a simulated trip has and a filter assumes when none is named
#: (`strapdown.imu_errors.IMU_GRADES`).
DEFAULT_IMU_GRADE = "tactical"
#: The filter of sensor files without an IMU (`default_filter`).
NO_IMU_FILTER = "gnss-only"
#: Random seed of a simulated trip when none is given: `railnav.simulate_trip`,
#: `railnav.run_simulated` and their kin, ``railnav simulate``, ``run``, ``network run``.
DEFAULT_SEED = 0
#: GNSS systems simulated and used when none are named (the 2017 paper uses one system),
#: by every command and public function of railnav, ``railnav spp`` and `spp_files`
#: included. The library's own default, `gnss_obs.MeasurementConfig`'s (so
#: ``gnss_obs.SppConfig()``'s), is ``"GE"``: `railnav.jobs.spp` says why they differ.
DEFAULT_SYSTEMS = "G"
#: ``railnav spp``: ionosphere handling when none is named
#: (`gnss_obs.corrections.IONOSPHERE_MODELS`; `gnss_obs.MeasurementConfig`'s too).
DEFAULT_IONOSPHERE = "klobuchar"
#: ``railnav spp``: satellites below this elevation are not used, deg
#: (`gnss_obs.SppConfig`'s too).
DEFAULT_ELEVATION_MASK_DEG = 10.0
#: Several tracks and networks: the rate of changing to a track abreast, 1/s
#: (`railnav.navigation.bank`'s module docstring: one crossing per ~28 h of running).
DEFAULT_CROSSING_RATE_PER_S = 1e-5
#: Track networks: how far ahead of a start the routes through the switches are followed,
#: m (`railnav.jobs.network`).
DEFAULT_HORIZON_M = 5_000.0
#: 1σ white noise of an odometer reading without a σ of its own, m/s
#: (`railnav.filters.odometer_epochs.OdometerConfig`, which explains it).
DEFAULT_ODOMETER_SIGMA_MPS = 0.05
#: 1σ of a balise passage without a σ of its own, m
#: (`railnav.filters.balise_epochs.BaliseModelConfig`, which explains it).
DEFAULT_BALISE_SIGMA_M = 1.0
#: ``railnav network run``, `railnav.run_simulated_route`: the constant speed of a trip
#: simulated along a route of a network, m/s.
DEFAULT_NETWORK_SPEED_MPS = 20.0


def default_filter(filter: str | None, *, imu: bool) -> str:
    """`filter`, else the filter a run on sensor files uses: `DEFAULT_FILTER` with an IMU,
    ``"gnss-only"`` without (`railnav.run_files`, `run_files_tracks`, `run_files_network`
    and ``railnav run`` by the same rule); a simulated trip has an IMU."""
    return filter or (DEFAULT_FILTER if imu else NO_IMU_FILTER)
