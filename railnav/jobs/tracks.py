"""Runs over several candidate tracks: the public API behind ``railnav run A.csv B.csv``.

A run over candidate tracks (the tracks of a double line, the routes after a switch) is a
network run (`railnav.jobs.network`) on the network of those tracks as netelements without
connections (`track_network`): one hypothesis per track (per orientation, for an inertial
filter started from files), weighted by the evidence of every epoch on a common basis, with
the Markov prior of crossing to a track abreast at `NetworkNavConfig.crossing_rate_per_s`
and the IMM restarts of the hypotheses abreast (`railnav.navigation.network_weights`).
`track_nav` gives the navigator's limits for such a run: the accelerometer
pseudo-observation is no evidence (the curvature of two tracks 4.5 m apart differs by
0.75 % in a 600-m curve, less than surveyed track geometry can be trusted;
`railnav.navigation.bank`); every track's hypothesis fits under the cap; and a track is
pruned only below `TRACK_PRUNE_PROBABILITY` (1e-30), so that the crossing prior keeps the
unlikely track alive (its floor is ~εΔt, 1e-5 at the default ε: the network's default
1e-7 drops it after a few strong epochs, and a crossing could no longer be followed),
while a hypothesis facing the wrong way (files, inertial filter: one per orientation at the
start) falls below it within tens of epochs.

* `run_simulated_tracks` simulates a scenario on one of the tracks (the *true* track, which
  the navigator is not told), each candidate starting from the truth brought onto its own
  track plus one common error draw;
* `run_files_tracks` does the same on recorded or ``railnav simulate`` files (GNSS
  observations, or position fixes), starting from the first fix projected onto each track,
  facing along the tracks (as given) unless told otherwise;
* `write_track_run` writes the files of `railnav.jobs.network.write_network_run`
  (``estimates.csv`` with the network columns and ``track``, ``track_probability``;
  ``innovations.csv`` with ``track``; ``hypotheses.csv``, ``route.csv``, ``network.png``),
  ``summary.json`` with ``tracks``, ``track_probabilities`` (final, by file stem),
  ``true_track`` (simulations), ``crossing_rate_per_s``, ``track_cycles``,
  ``track_runtime_s`` and the network's ``route``; ``track_probabilities.csv`` (every
  cycle), ``track_probabilities.png`` and ``track.png`` (every candidate).

A candidate track whose hypotheses are all gone (pruned below
`NetworkNavConfig.prune_probability`, or beyond its end) has probability 0 from then on; a
candidate farther than `NetworkNavConfig.start_radius_m` from the start is none.
"""
from __future__ import annotations

import logging
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np
import numpy.typing as npt
import pandas as pd

from railnav.config import NavigatorConfig
from railnav.defaults import DEFAULT_CROSSING_RATE_PER_S, DEFAULT_SEED, DEFAULT_SYSTEMS
from railnav.errors import ConfigError
from railnav.jobs.network import (
    NetworkRunOutcome,
    run_files_network,
    run_simulated_network,
    write_network_run,
)
from railnav.jobs.run import RunOutcome
from railnav.navigation.network_config import NetworkNavConfig
from railnav.navigation.result import CSV_DECIMALS, CSV_FLOAT_FORMAT
from railnav.simulation.scenarios import Scenario
from trackmodel.files import atomic_write_csv
from trackmodel.network import Network

__all__ = ["TrackRunOutcome", "TrackProbabilities", "run_simulated_tracks",
           "run_files_tracks", "write_track_run", "track_names", "track_network",
           "track_nav", "correct_share", "TRACK_PRUNE_PROBABILITY"]

Array = npt.NDArray[np.float64]

log = logging.getLogger(__name__)

#: A run over tracks drops a hypothesis below this probability (module docstring).
TRACK_PRUNE_PROBABILITY = 1e-30


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


def track_network(tracks, names) -> Network:
    """The candidate tracks as a network: one netelement per track (named `names`), no
    connections.

    Raises
    ------
    ConfigError
        Fewer than two tracks, or not one distinct name per track.
    """
    tracks, names = list(tracks), list(names)
    if len(tracks) < 2 or len(names) != len(tracks) or len(set(names)) != len(names):
        raise ConfigError("a run over candidate tracks needs at least two tracks with "
                          "distinct names")
    return Network(dict(zip(names, tracks)), [])


def track_nav(n_tracks: int, *, crossing_rate_per_s: float = DEFAULT_CROSSING_RATE_PER_S
              ) -> NetworkNavConfig:
    """The network navigator's configuration for a run over `n_tracks` candidates (module
    docstring): `NetworkNavConfig`'s defaults, no continuous evidence, room for a
    hypothesis per track and orientation, pruning at `TRACK_PRUNE_PROBABILITY`, and
    `crossing_rate_per_s`, the rate ε of changing to a track abreast (1/s, >= 0)."""
    base = NetworkNavConfig()
    return NetworkNavConfig(max_hypotheses=max(base.max_hypotheses, 2 * int(n_tracks)),
                            prune_probability=TRACK_PRUNE_PROBABILITY,
                            crossing_rate_per_s=crossing_rate_per_s,
                            continuous_evidence=False)


@dataclass(frozen=True, eq=False)
class TrackProbabilities:
    """Each candidate track's probability after every cycle of a run over tracks.

    Attributes
    ----------
    names : tuple of str
        The candidates, in the order of the columns.
    time_s : ndarray, shape (C,)
        End of each cycle, s from the trip start.
    probabilities : ndarray, shape (C, J)
        The probability of each track (the sum over its hypotheses).
    log_likelihoods : ndarray, shape (C, J)
        Each cycle's evidence for each track (its hypotheses' mixture likelihood; 0
        without evidence, −inf for a track without a hypothesis).
    common_rows : ndarray of int, shape (C,)
        Rows (GNSS or fix) the cycle's evidence was computed on (0: no evidence).
    start_gps_time_s : float
    """

    names: tuple[str, ...]
    time_s: Array
    probabilities: Array
    log_likelihoods: Array
    common_rows: npt.NDArray[np.int_]
    start_gps_time_s: float

    @classmethod
    def of(cls, result, names) -> "TrackProbabilities":
        """From a `railnav.navigation.network_result.NetworkResult` on `track_network`."""
        names = tuple(names)
        def table(per_cycle, missing: float) -> Array:
            return np.array([[p.get(n, missing) for n in names] for p in per_cycle],
                            dtype=float).reshape(-1, len(names))
        return cls(names, result.time_s, table(result.element_probability, 0.0),
                   table(result.element_log_likelihood, -np.inf),
                   result.cycles["evidence_rows"].to_numpy(dtype=int),
                   float(result.start_gps_time_s))

    def final(self) -> dict[str, float]:
        """The last cycle's probabilities by track name."""
        return {n: float(p) for n, p in zip(self.names, self.probabilities[-1])}

    def frame(self) -> pd.DataFrame:
        """``time_s, gps_time_s``, one column per track (its name) and ``common_rows``."""
        out = pd.DataFrame({"time_s": self.time_s,
                            "gps_time_s": self.time_s + self.start_gps_time_s})
        for j, name in enumerate(self.names):
            out[name] = self.probabilities[:, j]
        out["common_rows"] = self.common_rows
        return out


@dataclass(frozen=True, eq=False)
class TrackRunOutcome:
    """A finished run over candidate tracks.

    Attributes
    ----------
    outcome : railnav.jobs.run.RunOutcome
        The most probable hypothesis's estimates at each cycle (with ``track`` and
        ``track_probability``), the summary (module docstring) and the errors against a
        simulated truth.
    probabilities : TrackProbabilities
    network_run : railnav.jobs.network.NetworkRunOutcome
        The network run underneath (its `NetworkResult`, the network of the tracks).
    tracks : tuple of trackmodel.Track
    """

    outcome: RunOutcome
    probabilities: TrackProbabilities
    network_run: NetworkRunOutcome
    tracks: tuple


def run_simulated_tracks(tracks, names, scenario: Scenario, *, true_track: int = 0,
                         config: NavigatorConfig | None = None, seed: int = DEFAULT_SEED,
                         systems: str = DEFAULT_SYSTEMS, nav: NetworkNavConfig | None = None,
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
    nav : NetworkNavConfig, optional
        Default ``track_nav(len(tracks))``.
    window : (start_s, end_s), optional
        Extra error-summary window.
    faults : tuple of gnss_obs.SatelliteFault
    progress : callable(done, total), optional
    """
    if not 0 <= true_track < len(tracks):
        raise ConfigError(f"true track {true_track + 1} is not one of the {len(tracks)} tracks")
    network = track_network(tracks, names)
    run = run_simulated_network(network, [(names[true_track], 1)], scenario,
                                line=tracks[true_track], config=config, seed=seed,
                                systems=systems, nav=nav or track_nav(len(tracks)),
                                start_direction=1, faults=faults, window=window,
                                progress=progress)
    return _track_outcome(run, tracks, names, {"true_track": names[true_track]})


def run_files_tracks(tracks, names, *, imu_path=None, obs_path=None, nav_path=None,
                     fixes_path=None, start_gps_time_s: float | None = None,
                     config: NavigatorConfig | None = None, filter: str | None = None,
                     systems: str | None = None, imu_grade: str | None = None,
                     fix_sigmas=None, fix_model=None, outages=None,
                     nav: NetworkNavConfig | None = None, direction: int | None = 1,
                     window: tuple[float, float] | None = None,
                     progress: Callable[[int, int], None] | None = None) -> TrackRunOutcome:
    """Identify the track of recorded (or simulated) sensor files among `tracks`.

    Parameters are those of `railnav.jobs.network.run_files_network` (the sensor files, the
    filter and fix model; `filter` default `railnav.defaults.default_filter`'s: the
    constrained filter with `imu_path`, else the gnss-only one, as ``railnav run``'s),
    plus the candidate `tracks`, their `names`, `nav` (default ``track_nav(len(tracks))``)
    and the `direction` the vehicle faces on them (+1: along ``s``, as the tracks are
    given; -1; None: either, one inertial hypothesis per track and orientation).
    """
    from railnav.navigation.network_start import NetworkStart
    network = track_network(tracks, names)
    run = run_files_network(network, fixes_path=fixes_path, imu_path=imu_path,
                            obs_path=obs_path, nav_path=nav_path,
                            start=None if direction is None else NetworkStart(
                                None, direction=direction),
                            nav=nav or track_nav(len(tracks)),
                            start_gps_time_s=start_gps_time_s, config=config, filter=filter,
                            systems=systems, imu_grade=imu_grade, fix_sigmas=fix_sigmas,
                            fix_model=fix_model, outages=outages, window=window,
                            progress=progress)
    return _track_outcome(run, tracks, names, {})


def _track_outcome(run: NetworkRunOutcome, tracks, names, extra: dict) -> TrackRunOutcome:
    """The network run as a run over tracks: the track columns and summary fields."""
    res, outcome = run.network_result, run.outcome
    probs = TrackProbabilities.of(res, names)
    missing = [n for n in names if n not in res.element_probability[0]]
    if missing:
        log.warning("candidate track(s) %s got no start hypothesis: farther than %g m from "
                    "the start, or running the other way", ", ".join(missing),
                    res.nav.start_radius_m)
    est = outcome.result.estimates
    est["track"] = est["netelement"]
    est["track_probability"] = est["netelement_probability"]
    inn = outcome.result.innovations
    inn["track"] = pd.Series(res.cycles["netelement"].to_numpy(), index=res.time_s
                             ).groupby(level=0).last().reindex(inn["time_s"]).to_numpy()
    best = list(names).index(est["track"].iloc[-1])
    summary = {**outcome.summary, **extra, "tracks": list(names),
               "track_probabilities": probs.final(),
               "crossing_rate_per_s": res.nav.crossing_rate_per_s,
               "track_cycles": int(probs.time_s.size), "track_runtime_s": res.runtime_s}
    track = outcome.track if outcome.trip is not None else tracks[best]   # else oriented
    summary["track"] = {"length_m": float(track.length_m), "earth": track.earth.name}
    out = RunOutcome(outcome.result, track, summary, outcome.errors, outcome.trip,
                     outcome.truth, outcome.data)
    return TrackRunOutcome(out, probs, run, tuple(tracks))


def write_track_run(run: TrackRunOutcome, out_dir: str | os.PathLike, *,
                    plots: bool = True) -> list[Path]:
    """Write a run over candidate tracks into `out_dir` (module docstring)."""
    out = Path(out_dir)
    written = write_network_run(replace(run.network_run, outcome=run.outcome), out,
                                plots=plots)
    atomic_write_csv(out / "track_probabilities.csv", run.probabilities.frame(),
                     float_format=CSV_FLOAT_FORMAT, decimals=CSV_DECIMALS)
    written.append(out / "track_probabilities.csv")
    if plots:
        from railnav.evaluation.map_plots import plot_track_estimate
        from railnav.evaluation.plot_style import outage_spans
        from railnav.evaluation.track_plots import plot_track_probabilities
        plot_track_estimate(list(run.tracks), run.outcome.result, out / "track.png",
                            truth=run.outcome.truth, names=run.probabilities.names)
        plot_track_probabilities(run.probabilities, out / "track_probabilities.png",
                                 outages=outage_spans(run.outcome.result))
        written += [out / "track.png", out / "track_probabilities.png"]
    return written


def correct_share(probabilities: TrackProbabilities, true_name: str, *, after_s: float,
                  level: float) -> float:
    """Share of the cycles with evidence after `after_s` at which the probability of
    `true_name` exceeds `level` (the parallel-track acceptance figure)."""
    j = list(probabilities.names).index(true_name)
    late = (probabilities.time_s > after_s) & (probabilities.common_rows > 0)
    return float(np.mean(probabilities.probabilities[late, j] > level)) if late.any() \
        else float("nan")
