"""The ``summary.json`` content of a run (`run_summary`), shared by every kind of run
(`railnav.jobs.run`, `railnav.jobs.tracks`, `railnav.jobs.network`)."""
from __future__ import annotations

from railnav.evaluation.metrics import summarize
from railnav.navigation.result import NavigationResult

__all__ = ["run_summary"]


def run_summary(result: NavigationResult, track, errors, window, outages, extra: dict) -> dict:
    """The ``summary.json`` content of a run: filter, track, duration, statistics, left
    track, `extra` keys, and with `errors` their summary (`railnav.evaluation.metrics.summarize`)."""
    est = result.estimates
    out = {"filter": result.filter, **extra,
           "track": {"length_m": float(track.length_m), "earth": track.earth.name},
           "start_gps_time_s": result.start_gps_time_s,
           "duration_s": float(est["time_s"].iloc[-1] - est["time_s"].iloc[0]) if len(est) else 0.0,
           "steps": result.n_steps, "outages": [list(o) for o in outages],
           "runtime_s": result.runtime_s, "statistics": result.statistics(),
           "left_track": result.left_track}
    if errors is not None:
        out["errors"] = summarize(errors, window=window, outages=outages)
    return out
