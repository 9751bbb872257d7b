"""The figures of a one-track run (``errors.png`` or ``estimates.png``, ``track.png``) as
`railnav.jobs.plot_worker.Figure` s, and the plot helper that draws them while the run
writes its tables (`railnav.jobs.run.write_run`): what is sent to the helper process is
what the figures read.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from railnav.jobs.plot_worker import Figure, PlotHelper

__all__ = ["run_plot_helper", "run_figures", "TruthPath"]


def run_plot_helper(filter_name: str, truth: bool) -> PlotHelper:
    """The plot helper (`railnav.jobs.plot_worker`) of a one-track run with `filter_name`,
    for `write_run`: it lays out ahead the map and, with a truth, ``errors.png``
    (`railnav.evaluation.plots.lay_out_run`)."""
    return PlotHelper(Figure("railnav.evaluation.plots.lay_out_run", (filter_name, truth)))


def run_figures(outcome, out: Path) -> list[Figure]:
    """The figures of a run (`outcome`: a `railnav.jobs.run.RunOutcome`;
    `railnav.evaluation.plots`): ``errors.png`` with a truth that
    has samples of the run, else ``estimates.png``; ``track.png``. Their arguments are what
    the figures read, the part to send to a helper process: the result without its raw
    filter output, filter object, state and covariance history (not drawn), and of the
    truth its path (`TruthPath`)."""
    result = replace(outcome.result, raw=None, filter_object=None, x=None, P=None)
    plots = "railnav.evaluation.plots"
    first = (Figure(f"{plots}.plot_errors", (outcome.errors, result, out / "errors.png"),
                    path=out / "errors.png") if outcome.errors is not None
             and outcome.errors.compared else
             Figure(f"{plots}.plot_estimates", (result, out / "estimates.png"),
                    path=out / "estimates.png"))
    truth = None if outcome.truth is None else TruthPath.of(outcome.truth)
    return [first, Figure(f"{plots}.plot_track_estimate",
                          (outcome.track, result, out / "track.png"),
                          {"truth": truth}, path=out / "track.png")]


@dataclass(frozen=True)
class TruthPath:
    """What the map (`railnav.evaluation.map_plots.track_estimate_figure`) reads of a
    truth: its sample times (s) and geodetic path (rad, rad, m), the same arrays. A
    quarter of a simulated `railnav.simulation.truth.Truth` (12.8 of the 20 MB a
    1000-s trip's figures were): the rest is not sent to the plot helper."""

    time_s: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray

    @classmethod
    def of(cls, truth) -> TruthPath:
        return cls(truth.time_s, truth.lat, truth.lon, truth.h)
