"""A bank's inputs stacked (`railnav.filters.inputs_together`) against each filter's own
`ConstrainedFilter.inputs`, to the bit: members on different tracks (a curvy line, a
parallel of it, a straight line, a circle entered straight: a curvature step), one near
its track's end (the predicted path clamped there), one with a wide σ_s (the statistical
linearization), two on one track object."""
from __future__ import annotations

from dataclasses import fields, replace

import numpy as np
import pytest

import railnav.filters.geometry_noise as geometry_noise
from railnav.filters.constrained import ConstrainedFilter
from railnav.filters.geometry_noise import statistical_parameters, straight_priors
from railnav.filters.inputs_together import inputs_together
from railnav.filters.reference_path import paths_together
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for
from trackmodel.earth import WGS84
from trackmodel.io import read_track
from trackmodel.offset import offset_track
from trackmodel.sections import Section
from trackmodel.track import Origin, Track


def _tracks():
    curvy = read_track(TRACKS_DIR / "curvy.csv")
    circle = Track([Section(1000.0, 90.0, 0.0)]
                   + [Section(0.5 * np.pi * 300.0, None, None, 1.0 / 300.0)] * 4
                   + [Section(1000.0, None, None)], Origin(50.45, 30.52, 100.0), WGS84)
    return {"curvy": curvy, "parallel": offset_track(curvy, 4.5),
            "straight": read_track(TRACKS_DIR / "paper2017.csv"), "circle": circle}


#: (track, s0 m, v m/s, σ_s m) of each member: entering curves, the straight, the circle
#: across its curvature step, 2 m before the curvy line's end at 25 m/s (the path runs
#: past it), a wide prior, and a second member on the curvy track object.
MEMBERS = (("curvy", 4300.0, 15.0, 0.5), ("parallel", 4310.0, 20.0, 4.5),
           ("straight", 2000.0, 30.0, 1.0), ("circle", 990.0, 20.0, 0.3),
           ("curvy", None, 25.0, 0.2), ("curvy", 9330.0, 18.0, 6.0))


def _bank(grade: str):
    config = navigator_config_for(replace(get_scenario("curvy"), imu_errors=grade))
    tracks = _tracks()

    def filters():
        return [ConstrainedFilter(tracks[name], config, None) for name, *_ in MEMBERS]
    together, alone = filters(), filters()
    layout = together[0].layout
    priors = []
    for (name, s0, v, sigma) in MEMBERS:
        x = np.zeros(layout.size)
        x[layout.index("s")] = tracks[name].length_m - 2.0 if s0 is None else s0
        x[layout.index("v")], x[layout.index("pitch")] = v, 1e-3
        if "b_ax" in layout.names:
            x[layout.index("b_ax")] = 2e-3
        P = np.diag(np.full(layout.size, 1e-6))
        P[layout.index("s"), layout.index("s")] = sigma ** 2
        priors.append((x, P))
    return together, alone, priors


def _chunk(rng, t0: float):
    t = t0 + 0.01 * np.arange(1, 101)
    return t, np.column_stack([rng.normal(0.3, 0.05, t.size), rng.normal(0.0, 0.1, t.size),
                               np.full(t.size, 9.81), np.zeros((t.size, 2)),
                               rng.normal(0.02, 0.001, t.size)])


def _same_point(a, b) -> bool:
    return all(np.array_equal(getattr(a, f.name), getattr(b, f.name)) for f in fields(a))


@pytest.mark.parametrize("grade", ["tactical", "mems"])
def test_inputs_together_are_each_filters_inputs(grade):
    """Five chunks in a row: each member's inputs, track parameters, geometry noise and
    ``step_q_c`` equal its own filter's `inputs` (fresh filters, the same calls), and so
    do the state the calls leave (the track at the chunk's end, the grid's window); the
    bank mixes straight priors and priors that take the statistical path."""
    together, alone, priors = _bank(grade)
    rng = np.random.default_rng(11)
    t0, kinds = 10.0, set()
    for _ in range(5):
        t, u = _chunk(rng, t0)
        X = np.array([x for x, _ in priors])
        s_pred = paths_together(together, t, u, X, t0)[1]
        sigma = np.array([f.prior_spread(x, P)[0] for f, (x, P) in zip(together, priors)])
        speed = np.array([f.prior_spread(x, P)[1] for f, (x, P) in zip(together, priors)])
        kinds.update(straight_priors([f.track for f in together], s_pred, sigma_s_m=sigma,
                                     interval_m=speed * 0.01))
        got = inputs_together(together, t, u, priors, t0)
        for f, g, (x, P), one in zip(together, alone, priors, got):
            ref = g.inputs(t, u, x, P, t0)
            assert all(np.array_equal(a, b) for a, b in zip(one, ref))
            assert np.array_equal(f.step_q_c, g.step_q_c)
            assert _same_point(f._chunk_end, g._chunk_end)
            assert (f._grid._lo, f._grid._hi) == (g._grid._lo, g._grid._hi)
        priors = [(x + 0.0, P) for x, P in priors]
        for x, _ in priors:
            x[together[0].layout.index("s")] += 15.0
        t0 = float(t[-1])
    assert kinds == {True, False}
    end = together[4]
    assert end._chunk_end.s == end.track.length_m           # the path clamped at the end


def test_paths_together_are_each_filters_prediction():
    """`paths_together` row k equals filter k's `_along_accel` and `predict_s`, to the bit
    (biases, pitch and gravity per member; the clamp at the track's end)."""
    together, _, priors = _bank("tactical")
    t, u = _chunk(np.random.default_rng(2), 5.0)
    accel, s = paths_together(together, t, u, np.array([x for x, _ in priors]), 5.0)
    for k, (f, (x, _)) in enumerate(zip(together, priors)):
        a = f._along_accel(u, x)
        assert np.array_equal(accel[k], a)
        assert np.array_equal(s[k], f.predict_s(t, a, x, 5.0))
    assert s[4, -1] == together[4].track.length_m


def test_straight_priors_are_the_short_cut(monkeypatch):
    """`straight_priors` says True exactly where `statistical_parameters` takes its short
    cut (no grid lookup over the prior: `_nodes` not called; zero variance)."""
    together, _, priors = _bank("tactical")
    t, u = _chunk(np.random.default_rng(4), 5.0)
    s = paths_together(together, t, u, np.array([x for x, _ in priors]), 5.0)[1]
    sigma = np.array([1e-3, 4.5, 200.0, 0.3, 0.2, 6.0])
    speed = np.array([15.0, 20.0, 30.0, 20.0, 25.0, 18.0])
    flags = straight_priors([f.track for f in together], s, sigma_s_m=sigma,
                            interval_m=speed * 0.01)
    calls = []
    inner = geometry_noise._nodes
    monkeypatch.setattr(geometry_noise, "_nodes", lambda *a, **k: calls.append(1) or inner(*a, **k))
    for k, f in enumerate(together):
        calls.clear()
        params = f._grid.parameters(s[k])[0]
        _, variance = statistical_parameters(f._grid, params, sigma_s_m=float(sigma[k]),
                                             speed_mps=float(speed[k]),
                                             interval_m=float(speed[k] * 0.01), s_m=s[k])
        assert flags[k] == (not calls)
        if flags[k]:
            assert not variance.any()
    assert flags[2] and not flags[0]


def test_one_filter_twice_goes_one_by_one():
    """The same filter object twice: each call as the filter's own in a row (its grid
    and memory touched twice, in order)."""
    together, alone, priors = _bank("mems")
    t, u = _chunk(np.random.default_rng(7), 5.0)
    got = inputs_together([together[0], together[0]], t, u, priors[:2], 5.0)
    for (x, P), one in zip(priors[:2], got):
        ref = alone[0].inputs(t, u, x, P, 5.0)
        assert all(np.array_equal(a, b) for a, b in zip(one, ref))
