"""Runs over several candidate tracks: the public API behind ``railnav run A.csv B.csv``.

* `run_simulated_tracks` simulates a scenario on one of the tracks (the *true* track, which
  the bank is not told) and identifies it among all of them (`railnav.navigation.bank`), each
  filter starting from the truth brought onto its own track plus one common error draw;
* `run_files_tracks` does the same on recorded or ``railnav simulate`` files, starting
  from the first GNSS fix projected onto each track;
* `write_track_run` writes the files of `railnav.jobs.run.write_run` for the combined result
  (``estimates.csv`` with ``track`` and ``track_probability``, ``innovations.csv`` with
  ``track``), ``summary.json`` with ``track_probabilities`` (final, by file stem),
  ``track_probabilities.csv`` (every cycle) and ``track_probabilities.png``.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from railnav.config import DEFAULT_FILTER, DEFAULT_SYSTEMS, NavigatorConfig
from railnav.errors import ConfigError
from railnav.evaluation.metrics import error_series
from railnav.jobs.run import (
    RunOutcome,
    read_sensor_files,
    run_summary,
    truth_start,
    write_run,
)
from railnav.navigation.bank import TrackBankConfig, convert_state, navigate_tracks
from railnav.navigation.bank_result import TrackBankResult
from railnav.navigation.result import CSV_DECIMALS, CSV_FLOAT_FORMAT
from railnav.simulation.scenarios import Scenario
from railnav.simulation.trip import navigator_config_for, simulate_trip
from trackmodel.files import atomic_write_csv

__all__ = ["TrackRunOutcome", "run_simulated_tracks", "run_files_tracks", "write_track_run",
           "track_names", "correct_share"]


@dataclass(frozen=True, eq=False)
class TrackRunOutcome:
    """A finished run over candidate tracks.

    Attributes
    ----------
    outcome : railnav.jobs.run.RunOutcome
        The combined result (most probable track at each time), its summary with
        ``tracks``, ``track_probabilities`` (and ``true_track`` for simulations) and its
        errors against the truth when known.
    bank : TrackBankResult
    """

    outcome: RunOutcome
    bank: TrackBankResult


def track_names(paths) -> tuple[str, ...]:
    """The names of candidate tracks: their file stems (distinct).

    Raises
    ------
    ConfigError
        Two files with one stem.
    """
    names = tuple(Path(p).stem for p in paths)
    if len(set(names)) != len(names):
        raise ConfigError(f"candidate tracks need distinct file names (stems): {names}")
    return names


def run_simulated_tracks(tracks, names, scenario: Scenario, *, true_track: int = 0,
                         config: NavigatorConfig | None = None, seed: int = 0,
                         systems: str = DEFAULT_SYSTEMS, bank: TrackBankConfig = TrackBankConfig(),
                         window: tuple[float, float] | None = None, faults: tuple = (),
                         progress: Callable[[int, int], None] | None = None
                         ) -> TrackRunOutcome:
    """Simulate `scenario` on ``tracks[true_track]`` and identify it among `tracks`.

    Parameters
    ----------
    tracks : sequence of trackmodel.Track
    names : sequence of str
        One per track (file stems).
    scenario : Scenario
    true_track : int
        Index of the track the trip is simulated on.
    config : NavigatorConfig, optional
        Default `railnav.simulation.trip.navigator_config_for(scenario)`.
    seed : int
    systems : str
    bank : TrackBankConfig
    window : (start_s, end_s), optional
        Extra error-summary window.
    faults : tuple of gnss_obs.SatelliteFault
    progress : callable(done, total), optional
    """
    if not 0 <= true_track < len(tracks):
        raise ConfigError(f"true track {true_track + 1} is not one of the {len(tracks)} tracks")
    config = config or navigator_config_for(scenario, systems=systems)
    trip = simulate_trip(scenario, track=tracks[true_track], seed=seed, systems=systems,
                         faults=faults)

    def initial(filters):
        truth_filter = filters[true_track]
        x_true = truth_filter.truth_states(trip.truth,
                                           *trip.clock_truth(trip.truth.time_s))[0][0]
        P0 = truth_start(truth_filter, trip, config).P0
        return [truth_start(f, trip, config, x_true=convert_state(truth_filter, f, x_true, P0)[0])
                for f in filters]

    result = navigate_tracks(tracks, trip.sensor_data(), config, names=names,
                             outages=scenario.outages, initial=initial, bank=bank,
                             progress=progress)
    combined = result.combined()
    errors = error_series(combined, trip.truth, trip.track, clock_truth=trip.clock_truth)
    extra = {"scenario": scenario.name, "seed": int(seed), "systems": systems,
             "true_track": names[true_track]}
    summary = _with_tracks(run_summary(combined, trip.track, errors, window, scenario.outages,
                                       extra), result)
    return TrackRunOutcome(RunOutcome(combined, trip.track, summary, errors, trip, trip.truth),
                           result)


def run_files_tracks(tracks, names, *, imu_path=None, obs_path=None, nav_path=None,
                     start_gps_time_s: float | None = None,
                     config: NavigatorConfig | None = None, systems: str | None = None,
                     imu_grade: str | None = None, outages=(), bank: TrackBankConfig = TrackBankConfig(),
                     window: tuple[float, float] | None = None,
                     progress: Callable[[int, int], None] | None = None) -> TrackRunOutcome:
    """Identify the track of recorded (or simulated) sensor files among `tracks`.

    Parameters are those of `railnav.jobs.run.run_files` (the filter is the default one),
    plus the candidate `tracks`, their `names` and the `bank` configuration.
    """
    data, config = read_sensor_files(imu_path=imu_path, obs_path=obs_path, nav_path=nav_path,
                                     start_gps_time_s=start_gps_time_s, config=config,
                                     filter=DEFAULT_FILTER, systems=systems,
                                     imu_grade=imu_grade)
    result = navigate_tracks(tracks, data, config, names=names, outages=outages, bank=bank,
                             progress=progress)
    combined = result.combined()
    best = list(names).index(combined.estimates["track"].iloc[-1])
    summary = _with_tracks(run_summary(combined, tracks[best], None, window, tuple(outages),
                                       {}), result)
    return TrackRunOutcome(RunOutcome(combined, tracks[best], summary), result)


def _with_tracks(summary: dict, result: TrackBankResult) -> dict:
    probs = result.probabilities
    return {**summary, "tracks": list(result.names),
            "track_probabilities": result.final_probabilities(),
            "crossing_rate_per_s": result.bank.crossing_rate_per_s,
            "track_cycles": int(probs.shape[0]),
            "track_runtime_s": result.runtime_s}


def write_track_run(run: TrackRunOutcome, out_dir: str | os.PathLike, *,
                    plots: bool = True) -> list[Path]:
    """Write a run over candidate tracks into `out_dir` (module docstring)."""
    out = Path(out_dir)
    written = write_run(run.outcome, out, plots=plots)
    if plots:    # the map again, with every candidate track (write_run draws the best one)
        from railnav.evaluation.map_plots import plot_track_estimate
        plot_track_estimate([r.filter_object.track for r in run.bank.results],
                            run.outcome.result, out / "track.png", truth=run.outcome.truth,
                            names=run.bank.names)
    atomic_write_csv(out / "track_probabilities.csv", run.bank.probability_frame(),
                     float_format=CSV_FLOAT_FORMAT, decimals=CSV_DECIMALS)
    written.append(out / "track_probabilities.csv")
    if plots:
        from railnav.evaluation.plot_style import outage_spans
        from railnav.evaluation.track_plots import plot_track_probabilities
        plot_track_probabilities(run.bank, out / "track_probabilities.png",
                                 outages=outage_spans(run.outcome.result))
        written.append(out / "track_probabilities.png")
    return written


def correct_share(bank: TrackBankResult, true_name: str, *, after_s: float,
                  level: float) -> float:
    """Share of the GNSS epochs after `after_s` (cycles with evidence) at which the
    probability of `true_name` exceeds `level` (the issue's acceptance figure)."""
    j = list(bank.names).index(true_name)
    late = (bank.time_s > after_s) & (bank.common_rows > 0)
    return float(np.mean(bank.probabilities[late, j] > level)) if late.any() else float("nan")
