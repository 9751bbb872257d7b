"""The filter protocol and the one registry of filter kinds (issue 12).

Reference: the registry is the only list of kinds, so every reader of it (the CLI's
--filter choices, NavigatorConfig's check, streaming, the bank) must agree with it, and
every registered kind must build an object that satisfies the protocol.
"""
from __future__ import annotations

from dataclasses import replace

import pytest

from railnav.cli import build_parser
from railnav.config import NavigatorConfig
from railnav.errors import ConfigError
from railnav.filters.protocol import FILTER_KINDS, FILTERS, Filter, filter_kind, make_filter
from railnav.simulation.scenarios import TRACKS_DIR
from trackmodel.io import read_track


@pytest.fixture(scope="module")
def track():
    return read_track(TRACKS_DIR / "paper2017.csv")


@pytest.mark.parametrize("kind", FILTER_KINDS)
def test_every_registered_kind_builds_a_protocol_object(track, kind):
    filt = make_filter(track, NavigatorConfig(filter=kind), None)
    assert isinstance(filt, Filter)
    assert type(filt).__name__ == FILTERS[kind].class_name
    assert filt.q_c.ndim == 1 and filt.q_c.size == filt.process.n_w


def test_the_cli_offers_exactly_the_registered_kinds():
    run = build_parser()._subparsers._group_actions[0].choices["run"]
    choices = next(a.choices for a in run._actions if a.dest == "filter")
    assert tuple(choices) == FILTER_KINDS


def test_an_unknown_kind_is_a_config_error_naming_the_kinds():
    with pytest.raises(ConfigError, match="constrained, unconstrained, gnss-only"):
        NavigatorConfig(filter="particle")
    with pytest.raises(ConfigError):
        filter_kind("particle")


def test_streaming_and_the_bank_read_the_registry():
    from railnav.navigation.streaming import stream_simulated
    from railnav.simulation.scenarios import get_scenario
    not_streaming = [k for k in FILTER_KINDS if not FILTERS[k].streams]
    assert not_streaming == ["gnss-only"]
    config = replace(NavigatorConfig(), filter=not_streaming[0])
    with pytest.raises(ConfigError, match="streaming runs the constrained and unconstrained"):
        stream_simulated(None, get_scenario("paper2017"), config=config)
