"""Figures laid out before their data come (`railnav.evaluation.plot_style.lay_out_ahead`,
`railnav.evaluation.plots.lay_out_run`, what the plot helper does while a run filters).

References: the same figures made from scratch must be the same PNG bytes; the panels
`lay_out_run` expects of each filter must be the ones `errors_figure` draws for that
filter's estimates (a short simulated run of each).
"""
from __future__ import annotations

from dataclasses import replace

import pytest

import railnav.evaluation.plot_style as plot_style
from railnav.evaluation.map_plots import plot_track_estimate
from railnav.evaluation.plots import (
    ERROR_PANELS_OF_FILTER,
    _error_panels,
    lay_out_run,
    plot_errors,
)
from railnav.jobs.run import run_simulated
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for

PAPER = str(TRACKS_DIR / "paper2017.csv")


def _run(filter_name: str):
    scenario = replace(get_scenario("paper2017"), duration_s=20.0, outages=())
    config = navigator_config_for(scenario, filter=filter_name, systems="G")
    return run_simulated(PAPER, scenario, config=config, seed=1, systems="G")


@pytest.fixture(scope="module")
def constrained():
    return _run("constrained")


def _draw(outcome, tmp_path, tag: str) -> tuple[bytes, bytes]:
    errors, track = tmp_path / f"errors_{tag}.png", tmp_path / f"track_{tag}.png"
    plot_errors(outcome.errors, outcome.result, errors)
    plot_track_estimate(outcome.track, outcome.result, track, truth=outcome.truth)
    return errors.read_bytes(), track.read_bytes()


def test_figures_laid_out_ahead_are_the_same_bytes(constrained, tmp_path, monkeypatch):
    monkeypatch.setattr(plot_style, "_AHEAD", {})
    made_now = _draw(constrained, tmp_path, "now")
    lay_out_run("constrained", True)
    assert sum(map(len, plot_style._AHEAD.values())) == 2      # errors.png and the map
    ahead = _draw(constrained, tmp_path, "ahead")
    assert not any(plot_style._AHEAD.values())                 # both used, once
    assert ahead == made_now


@pytest.mark.parametrize("filter_name", sorted(ERROR_PANELS_OF_FILTER))
def test_each_filter_has_the_panels_laid_out_for_it(filter_name, constrained):
    outcome = constrained if filter_name == "constrained" else _run(filter_name)
    assert len(_error_panels(outcome.result.estimates)) == ERROR_PANELS_OF_FILTER[filter_name]
