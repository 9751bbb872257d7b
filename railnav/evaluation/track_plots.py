"""Plots of parallel-track identification: the track probabilities over time.

Same conventions as `railnav.evaluation.plot_style` (a `matplotlib.figure.Figure`, GNSS
outages shaded, words and units on every axis).
"""
from __future__ import annotations

import os

import numpy as np
from matplotlib.figure import Figure

from railnav.evaluation.plot_style import (
    TIME_LABEL,
    outage_legend_handle,
    save_png,
    shade_outages,
)

__all__ = ["track_probabilities_figure", "plot_track_probabilities", "MIN_MISS"]

#: Floor of the "1 − p" axis (probabilities within this of 1 are drawn at it).
MIN_MISS = 1e-6


def track_probabilities_figure(bank, *, outages=()) -> Figure:
    """Each candidate's probability (top) and its distance to 1 on a log axis (bottom).

    Parameters
    ----------
    bank : railnav.jobs.tracks.TrackProbabilities
        Its ``names``, ``time_s`` and ``probabilities``.
    outages : sequence of (start_s, duration_s)
        Shaded (`railnav.evaluation.plot_style.outage_spans` of the run: declared outages
        and gaps in the GNSS data).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = Figure(figsize=(9, 5.5), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True)
    for j, name in enumerate(bank.names):
        p = bank.probabilities[:, j]
        top.plot(bank.time_s, p, lw=1.2, label=name)
        bottom.semilogy(bank.time_s, np.maximum(1.0 - p, MIN_MISS), lw=1.0, label=name)
    for ax in (top, bottom):
        shade_outages(ax, outages)
        ax.grid(True, alpha=0.3)
    top.set_ylabel("probability of the track")
    top.set_ylim(-0.02, 1.02)
    handles, _ = top.get_legend_handles_labels()
    if len(outages):
        handles.append(outage_legend_handle())
    top.legend(handles=handles, loc="center right")
    bottom.set_ylabel(f"1 − probability (floor {MIN_MISS:g})")
    bottom.set_xlabel(TIME_LABEL)
    fig.suptitle("which track: probability of each candidate")
    return fig


def plot_track_probabilities(bank, path: str | os.PathLike, *, outages=()) -> None:
    """`track_probabilities_figure` written to a PNG file."""
    save_png(track_probabilities_figure(bank, outages=outages), path)
