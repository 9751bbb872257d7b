"""What a streamed run (`railnav.navigation.streaming`) writes and counts as it goes: the
decimated ``estimates.csv`` and ``errors.csv`` rows (`StreamWriter`), the divergence
monitor's counts with its records dropped once counted (`StreamMonitor`), and
``summary.json`` (`stream_summary`). Nothing here grows with the trip."""
from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np
import pandas as pd

from railnav.config import NavigatorConfig
from railnav.evaluation.running_stats import RunningCounts, RunningSummary
from railnav.navigation.loop import EPOCH_TIME_TOL_S
from railnav.navigation.statuses import STATUSES
from railnav.navigation.result import CSV_DECIMALS, CSV_FLOAT_FORMAT, integrity_columns
from railnav.simulation.scenarios import Scenario
from trackmodel.csv_table import write_csv
from trackmodel.files import atomic_write

__all__ = ["StreamWriter", "StreamMonitor", "stream_summary"]


class StreamWriter:
    """Appends decimated rows to ``estimates.csv`` and ``errors.csv`` (temporary files
    replaced at the end of the run; removed if it fails)."""

    def __init__(self, files: contextlib.ExitStack, out: Path | None, rate_hz: float) -> None:
        self.rate_hz = rate_hz
        self.handles = {}
        self.paths: tuple[Path, ...] = ()
        if out is not None:
            for name in ("estimates.csv", "errors.csv"):
                self.handles[name] = files.enter_context(atomic_write(out / name, "wb"))
                self.paths += (out / name,)
        self._header = True

    def write(self, estimates: pd.DataFrame, errors: pd.DataFrame) -> None:
        if not self.handles:
            return
        k = estimates["time_s"].to_numpy() * self.rate_hz
        keep = np.abs(k - np.round(k)) < EPOCH_TIME_TOL_S * self.rate_hz
        for name, frame in (("estimates.csv", estimates), ("errors.csv", errors)):
            write_csv(self.handles[name], frame[keep], header=self._header,
                      float_format=CSV_FLOAT_FORMAT, decimals=CSV_DECIMALS)
        self._header = False


class StreamMonitor:
    """The divergence monitor of a streamed run: its records are counted and dropped as
    the blocks they cover are written (the last one kept: the status in force), so they
    do not grow with the trip."""

    def __init__(self, monitor) -> None:
        self.monitor = monitor
        self.rows = {k: 0 for k in STATUSES}
        self.epochs = {k: 0 for k in STATUSES}
        self.recoveries = 0
        self._counted = 0                  # records at the head already counted (the kept one)

    def columns(self, estimates: pd.DataFrame, config) -> pd.DataFrame:
        """`estimates` with ``status`` and the protection columns (as a single-track run's,
        `railnav.navigation.result.integrity_columns`), counted; the records up to its
        last row are then counted and dropped."""
        records = self.monitor.records
        out = estimates.assign(**integrity_columns(estimates, self.monitor.frame(), config))
        counts = out["status"].value_counts()
        for k in STATUSES:
            self.rows[k] += int(counts.get(k, 0))
        t_end = float(estimates["time_s"].iloc[-1]) + EPOCH_TIME_TOL_S
        done = sum(1 for r in records if r["time_s"] <= t_end)
        for r in records[self._counted:done]:
            self.epochs[r["status"]] += 1
            self.recoveries += r["action"] != ""
        if done:
            del records[:done - 1]
            self._counted = 1
        return out

    def statistics(self) -> dict:
        """``statistics.monitor`` (the keys of `railnav.navigation.result.monitor_statistics`)."""
        records = self.monitor.records
        epochs, recoveries = dict(self.epochs), self.recoveries
        for r in records[self._counted:]:
            epochs[r["status"]] += 1
            recoveries += r["action"] != ""
        return {"epochs": epochs, "estimate_rows": dict(self.rows),
                "recoveries": int(recoveries),
                "final_status": str(records[-1]["status"]) if records else None}


def stream_summary(scenario: Scenario, config: NavigatorConfig, seed: int, systems: str, track,
             stats: RunningSummary, counts: RunningCounts, left: dict | None,
             monitored: StreamMonitor | None, runtime_s: float) -> dict:
    """``summary.json`` of a streamed run (the keys of `railnav.jobs.run`' summary)."""
    statistics = counts.statistics()
    if monitored is not None:
        statistics["monitor"] = monitored.statistics()
    duration = counts.last_time_s - counts.first_time_s if stats.samples else 0.0
    if left is not None:
        left = dict(left, gps_time_s=left["time_s"] + scenario.start_gps_time_s)
    return {"filter": config.filter, "scenario": scenario.name, "seed": int(seed),
            "systems": systems, "mode": "streaming",
            "track": {"length_m": float(track.length_m), "earth": track.earth.name},
            "start_gps_time_s": scenario.start_gps_time_s, "duration_s": duration,
            "steps": counts.steps, "outages": [list(o) for o in scenario.outages],
            "runtime_s": runtime_s, "statistics": statistics, "left_track": left,
            "errors": stats.summary()}
