"""railnav — track-constrained navigation of rail vehicles (the application).

Assembles the four library packages into scenarios (truth, sensors, faults), the
navigator (constrained, unconstrained and GNSS-only filters), the ``railnav`` command
line, plots and studies. Everything the CLI does is a public function here first, with
the same defaults; the main ones are importable from the package itself::

    from railnav import get_scenario, run_simulated, reproduce_paper2017, run_study

=====================================  ===========================================
command                                function(s)
=====================================  ===========================================
``railnav simulate``                   `simulate_trip`, `scenario_for_track`
                                       (`get_scenario`), `write_simulated_trip`
``railnav simulate --fixes-format F``  + `trip_fixes` (`simulate_fixes`, `FixSimConfig`),
                                       `gnss_obs.write_fixes_csv` / ``write_fixes_nmea``
``railnav run TRACK``                  `run_simulated` (on `scenario_for_track`),
                                       `run_files`, `write_run` (`navigate`
                                       underneath, `NavigatorConfig`)
``railnav run TRACK --fixes F``        `run_files` (`gnss_obs.read_fixes`, `FixModelConfig`)
``railnav run ... --truth R``          `score_run` (`read_reference`, `reference_errors`,
                                       `screen_fix_reference`)
``railnav run TRACK --smooth``         ``run_simulated``/``run_files(smooth=True)``
                                       (`smooth_result`, `smooth_outcome`;
                                       ``NavigatorConfig(rts_smoothing=True)``)
``railnav run TRACK --export F,...``    + `write_run_exports` (`write_exports`: GeoJSON,
                                       KML, GPX, NMEA)
``--out DIR [--overwrite]``            `trackmodel.files.output_directory` (every
                                       command: written whole or not at all)
``railnav run ... --imu-spec S``       `run_files(imu_spec=)` (`strapdown.read_imu_log`,
                                       `strapdown.ImuSpec`), `read_sensor_files`
``railnav run ... --odometer O``       `run_files(odometer_path=)` (`read_odometer_csv`,
``--balises B --lever-arm F,L,U``      `OdometerConfig`, `read_balises_csv`,
                                       `BaliseModelConfig`, `LeverArms`)
``railnav simulate --odometer``        + `simulate_odometer` (`OdometerSimConfig`,
``--balises --imu-jitter-s S``         `SlipEpisode`), `simulate_balises`
                                       (`BaliseSimConfig`), `simulate_imu_log`
                                       (`ImuLogSimConfig`)
``railnav run TRACK --baro B.csv``     + `read_baro_csv`, `add_run_baro`,
                                       `write_run_baro` (`check_run_baro`,
                                       `baro_track_check` underneath)
``railnav run TRACK_A TRACK_B``        `run_simulated_tracks`, `run_files_tracks`,
                                       `write_track_run` (`navigate_network` on
                                       `track_network`, `track_nav`)
``railnav reproduce NAME``             `run_experiment` (`reproduce_paper2017`,
                                       `reproduce_anomaly2021`)
``railnav study CONFIG.toml``          `load_study_config`, `run_study`
``railnav spp``                        `spp_files` -> `SppRun` (``.write``,
                                       ``.lines``; `gnss_obs.augment`,
                                       `gnss_obs.solve_spp`, `spp_errors`,
                                       `accuracy_summary` underneath); systems
                                       default G as every command (`gnss_obs`'s
                                       own `SppConfig` default is GE)
``railnav track fit SURVEY``           `fit_survey` (`read_survey`; `trackmodel.fit_track`)
``railnav track sample|info|plot``     `trackmodel` (`sample_track`, `track_info`, ...)
``railnav network import|build``       `import_network` (`trackmodel.load_network`,
                                       `check_network`, `write_network`)
``railnav network check|info``         `trackmodel.load_network`, `check_network`
                                       (`read_osm`, GeoJSON readers)
``railnav network route|plot``         `trackmodel.route_legs`, `route_track`,
                                       `Network.routes`; `plot_network_map`
``railnav simulate --network --route`` `simulate_trip` on `trackmodel.route_track`
``railnav run --network N ...``        `run_files_network`, `write_network_run`
                                       (`navigate_network` underneath, `NetworkNavConfig`,
                                       `NetworkStart`; track networks: `trackmodel.network`)
``railnav network run N --start E:S``  `run_simulated_route` (`route_scenario`,
                                       `run_simulated_network`) / `run_files_network`
``railnav network routes N --start``   `route_candidates` (the list ``--true-route``
                                       indexes)
=====================================  ===========================================

The names are imported on first use (PEP 562), so ``import railnav`` stays cheap;
``railnav.__version__`` is the installed distribution's version (package metadata).
"""
from __future__ import annotations

import importlib

#: Public name -> the module that owns it.
_EXPORTS = {
    "navigate": "navigation.navigator", "NavigatorConfig": "config",
    "NavigationResult": "navigation.result",
    "run_simulated": "jobs.run", "run_files": "jobs.run", "write_run": "jobs.run", "RunOutcome": "jobs.run",
    "simulate_trip": "simulation.trip", "navigator_config_for": "simulation.trip",
    "write_simulated_trip": "jobs.simulated_files", "import_network": "jobs.network_import",
    "read_survey": "jobs.survey", "fit_survey": "jobs.survey",
    "get_scenario": "simulation.scenarios", "Scenario": "simulation.scenarios",
    "scenario_for_track": "simulation.scenarios",
    "run_experiment": "reproduce.common", "reproduce_paper2017": "reproduce.paper2017",
    "reproduce_anomaly2021": "reproduce.anomaly2021",
    "run_study": "studies.study", "load_study_config": "studies.file", "StudyConfig": "studies.config",
    "stream_simulated": "navigation.streaming",
    "run_simulated_tracks": "jobs.tracks", "run_files_tracks": "jobs.tracks",
    "track_nav": "jobs.tracks", "write_track_run": "jobs.tracks",
    "FaultDetectionConfig": "filters.fault_config",
    "spp_files": "jobs.spp", "SppRun": "jobs.spp",
    "spp_errors": "evaluation.spp_accuracy", "accuracy_summary": "evaluation.spp_accuracy",
    "read_baro_csv": "jobs.baro", "check_run_baro": "jobs.baro",
    "add_run_baro": "jobs.baro", "write_run_baro": "jobs.baro",
    "write_run_exports": "jobs.export",
    "baro_track_check": "evaluation.baro",
    "route_candidates": "jobs.network", "run_simulated_network": "jobs.network",
    "run_files_network": "jobs.network", "write_network_run": "jobs.network",
    "run_simulated_route": "jobs.network_sim", "route_scenario": "jobs.network_sim",
    "navigate_network": "navigation.network_navigator",
    "NetworkNavConfig": "navigation.network_config", "NetworkStart": "navigation.network_start",
    "FixModelConfig": "filters.fix_epochs", "trip_fixes": "simulation.fixes",
    "simulate_fixes": "simulation.fixes", "FixSimConfig": "simulation.fixes",
    "score_run": "jobs.scoring", "read_reference": "evaluation.reference",
    "reference_errors": "evaluation.reference",
    "screen_fix_reference": "evaluation.reference",
    "smooth_result": "navigation.smoothing", "smooth_outcome": "jobs.smoothed",
    "write_exports": "jobs.export",
    "plot_network_map": "evaluation.network_map",
    "read_sensor_files": "jobs.sensor_files", "read_odometer_csv": "sensors.odometer",
    "read_balises_csv": "sensors.balises", "OdometerConfig": "filters.odometer_epochs",
    "BaliseModelConfig": "filters.balise_epochs", "LeverArms": "filters.track_frame",
    "simulate_odometer": "simulation.track_sensors",
    "OdometerSimConfig": "simulation.track_sensors", "SlipEpisode": "simulation.track_sensors",
    "simulate_balises": "simulation.track_sensors",
    "BaliseSimConfig": "simulation.track_sensors", "simulate_imu_log": "simulation.imu_logs",
    "ImuLogSimConfig": "simulation.imu_logs",
}

__all__ = sorted(_EXPORTS)   # and __version__, from the package metadata


def __getattr__(name: str):
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version
        try:
            value = version("railnav")
        except PackageNotFoundError:     # a source tree that was never installed
            value = "0+unknown"
        globals()[name] = value
        return value
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'railnav' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"railnav.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
