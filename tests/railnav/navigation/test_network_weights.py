"""The first Newton points of the mixing's conversions evaluated with the hypotheses'
track points (`railnav.navigation.network_weights.cycle_points`) against the conversions
evaluating them themselves (`railnav.navigation.state_conversion.converted_pairs` without
them): the same states and covariances to the bit, the same offsets remembered for the
next cycle."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from railnav.filters.constrained import ConstrainedFilter
from railnav.navigation import network_weights as nw
from railnav.navigation import state_conversion as sc
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for
from trackmodel.earth import C_n_e
from trackmodel.io import read_track
from trackmodel.network_points import points_on
from trackmodel.offset import offset_track


def _hyps(filters, s_values):
    out = []
    for filt, s in zip(filters, s_values):
        x = np.zeros(filt.layout.size)
        x[filt.layout.index("s")], x[filt.layout.index("v")] = s, 20.0
        P = np.diag(np.linspace(1e-6, 1e-2, filt.layout.size))
        out.append(SimpleNamespace(filt=filt, x=x, P=P, s_m=float(s)))
    return out


def _convert(hyps, pairs, points, guesses):
    return sc.converted_pairs([hyps[i].filt for i, _ in pairs],
                              [hyps[j].filt for _, j in pairs],
                              [hyps[i].x for i, _ in pairs], [hyps[i].P for i, _ in pairs],
                              source_points=[points[i] for i, _ in pairs],
                              first_guesses=guesses)


def test_cycle_points_give_the_conversions_their_own_numbers():
    config = navigator_config_for(get_scenario("curvy"))
    base = read_track(TRACKS_DIR / "double_a.csv")
    tracks = [offset_track(base, -4.5), base, offset_track(base, 4.5), base]
    filters = [ConstrainedFilter(t, config, None) for t in tracks]
    pairs = [(i, j) for j in range(4) for i in range(4) if i != j]
    sc.forget_offsets()
    try:
        first = _hyps(filters, [1000.0, 1001.0, 999.0, 1003.0])
        _convert(first, pairs, nw.track_points_of(first), None)   # offsets by projection
        hyps = _hyps(filters, [1020.0, 1021.5, 1018.0, 1024.0])
        table = dict(sc._OFFSETS)
        ref = _convert(hyps, pairs, nw.track_points_of(hyps), None)
        ref_table = dict(sc._OFFSETS)
        sc._OFFSETS.clear()
        sc._OFFSETS.update(table)
        points, newton = nw.cycle_points(hyps)
        assert set(newton) == set(pairs)       # every pair of tracks has an offset by now
        got = _convert(hyps, pairs, points, [newton.get(p) for p in pairs])
        assert sc._OFFSETS == ref_table
        for (x_a, P_a), (x_b, P_b) in zip(got, ref):
            assert np.array_equal(x_a, x_b) and np.array_equal(P_a, P_b)
        for p, q in zip(points, nw.track_points_of(hyps)):
            assert all(np.array_equal(getattr(p, f), getattr(q, f)) for f in p.FIELDS)
    finally:
        sc.forget_offsets()


def test_newton_steps_together_equal_each_pairs_own():
    """`_newton_many` (the waves' Newton steps in one stacked evaluation) against the step
    written out pair by pair (scalar rotation and products, ``s_g − (r_g − r_src)·C u``):
    the same ``s`` to the bit, and None where the step is longer than `NEWTON_MAX_STEP_M`."""
    base = read_track(TRACKS_DIR / "double_a.csv")
    left, right = offset_track(base, -4.5), offset_track(base, 4.5)
    s_src = np.array([500.0, 1500.0, 2500.0, 3001.0, 4000.0])
    targets = [left, right, left, right, left]
    sources = points_on([base] * 5, s_src.tolist())
    # the nearest points by projection, then guesses off them (the fourth: too far)
    nearest = np.array([t.project(p.lat, p.lon, p.h).s[0] for t, p in zip(targets, sources)])
    s_g = nearest + np.array([0.3, -0.7, 0.05, 2.5, -0.2])
    guesses = points_on(targets, s_g.tolist())
    together = sc._newton_many(guesses, sources, s_g.tolist())
    alone = []
    for g, p, s in zip(guesses, sources, s_g.tolist()):
        tangent = C_n_e(float(g.lat), float(g.lon)) @ np.asarray(g.u_n, dtype=float)
        step = -float((np.asarray(g.r_e) - np.asarray(p.r_e)) @ tangent)
        alone.append(s + step if abs(step) <= sc.NEWTON_MAX_STEP_M else None)
    assert together == alone
    assert together[3] is None and all(v is not None for k, v in enumerate(together)
                                       if k != 3)
