"""What a file run adds to a navigation: its truth, its scenario's outages, its time labels.

* `simulation_meta`: the ``scenario.json`` that ``railnav simulate`` writes beside its files;
  `scenario_outages` the outages it simulated (a file run honours and reports them) and
  `find_truth` the ``truth.csv`` beside it;
* `score_run`: the errors of a run against a reference file
  (`railnav.evaluation.reference`: truth.csv, a reference trajectory or a fix file);
* `with_timestamps`: ``estimates.csv`` with the fix file's UTC ``timestamp`` beside
  ``time_s`` and ``gps_time_s``.
"""
from __future__ import annotations

import dataclasses
import json
import logging
from pathlib import Path

from gnss_obs.gpstime import gps_time_s_to_utc_iso
from gnss_obs.sim_events import Outage
from railnav.errors import ConfigError
from railnav.evaluation.reference import read_reference, reference_errors

__all__ = ["simulation_meta", "scenario_outages", "file_outages", "find_truth", "score_run",
           "with_timestamps", "TRUTH_FILE"]

log = logging.getLogger(__name__)

#: The truth file ``railnav simulate`` writes beside ``scenario.json``.
TRUTH_FILE = "truth.csv"


def simulation_meta(*paths) -> tuple[dict, Path] | None:
    """The parsed ``scenario.json`` beside the first of `paths` that has one, and its path
    (None if none).

    Raises
    ------
    ConfigError
        A ``scenario.json`` that is not JSON.
    """
    for path in paths:
        if path is None:
            continue
        meta = Path(path).with_name("scenario.json")
        if meta.is_file():
            try:
                return json.loads(meta.read_text()), meta
            except ValueError as exc:
                raise ConfigError(f"not valid JSON ({exc})", path=meta) from None
    return None


def scenario_outages(meta: dict | None) -> tuple[Outage, ...]:
    """The outages a simulation's ``scenario.json`` lists (s from the trip start)."""
    if meta is None:
        return ()
    try:
        return tuple(Outage.of(o) for o in meta.get("scenario", {}).get("outages", []))
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"scenario.json: bad outages ({exc})") from None


def file_outages(outages, *paths) -> tuple[Outage, ...]:
    """The outages of a run on sensor files: `outages` as given (``()``: none), else (None)
    those of the ``scenario.json`` beside one of `paths` (``railnav simulate``'s files),
    else none. `railnav.jobs.run.run_files`' and `railnav.jobs.network.run_files_network`'s
    rule."""
    if outages is not None:
        return tuple(outages)
    found = simulation_meta(*paths)
    return scenario_outages(found[0] if found else None)


def find_truth(*paths) -> Path | None:
    """The ``truth.csv`` beside the ``scenario.json`` beside one of `paths` (None if
    none)."""
    found = simulation_meta(*paths)
    if found is None:
        return None
    truth = found[1].with_name(TRUTH_FILE)
    return truth if truth.is_file() else None


def score_run(result, track, truth_path, *, start_gps_time_s: float, quality=None,
              reference=None):
    """The errors of a run against a reference file, and the reference's report.

    Parameters
    ----------
    result : railnav.NavigationResult
    track : trackmodel.Track
    truth_path : path
        truth.csv, a reference trajectory or a fix file
        (`railnav.evaluation.reference.read_reference`).
    start_gps_time_s : float
        The run's trip start, GPS s.
    quality : str, optional
        A fix file's reference class (default its best).
    reference : railnav.evaluation.reference.Reference, optional
        `truth_path` already read (`read_reference`): a run scored twice (``--smooth``)
        reads it once.

    Returns
    -------
    errors : railnav.evaluation.metrics.ErrorSeries
    report : dict
    """
    if reference is None:
        reference = read_reference(truth_path, track, start_gps_time_s=start_gps_time_s,
                                   quality=quality)
    errors = reference_errors(result, reference, track)
    compared = errors.compared
    log.info("%s: %d estimates compared", truth_path, compared)
    return errors, {**reference.report, "estimates_compared": compared}


def with_timestamps(result, fixes):
    """`result` whose ``estimates`` carry ``timestamp`` (ISO 8601 UTC, the fix file's
    suffix) after ``gps_time_s``, for fix files with UTC labels; else `result`."""
    if fixes is None or fixes.time_scale != "UTC":
        return result
    est = result.estimates.copy()
    est.insert(2, "timestamp", gps_time_s_to_utc_iso(est["gps_time_s"].to_numpy(),
                                                     suffix=fixes.utc_suffix))
    return dataclasses.replace(result, estimates=est)
