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
        assert sc.known_offsets([f.track for f in filters]) == [
            (i, j, sc.known_offset(a.track, b.track)) for i, a in enumerate(filters)
            for j, b in enumerate(filters) if i != j and
            sc.known_offset(a.track, b.track) is not None]
        assert sc.known_offsets([tracks[0], read_track(TRACKS_DIR / "double_b.csv")]) == []
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


def test_states_moved_together_equal_the_turn_written_out_pair_by_pair():
    """`moved_states` (the conversions' states of one layout moved at once) against the
    move written out in Python floats pair by pair: ``s`` set, yaw turned by the azimuth
    difference wrapped to ±π (Python's ``%``), pitch by the elevation difference; the
    same bits, at turns either side of ±π too; `moved_state` (its case of one) alike."""
    from railnav.navigation.bank import moved_state, moved_states
    import math
    config = navigator_config_for(get_scenario("curvy"))
    filt = ConstrainedFilter(read_track(TRACKS_DIR / "double_a.csv"), config, None)
    lay = filt.layout
    rng = np.random.default_rng(21)
    K = 40
    xs = rng.normal(size=(K, lay.size))
    s_new = rng.uniform(0.0, 3000.0, K)
    az_src, az_tgt = rng.uniform(-math.pi, math.pi, K), rng.uniform(-math.pi, math.pi, K)
    az_tgt[:4] = az_src[:4] + np.array([math.pi, -math.pi, math.pi - 1e-12, 1e-300])
    el_src, el_tgt = rng.normal(0.0, 0.01, K), rng.normal(0.0, 0.01, K)
    got = moved_states(lay, xs, s_new, az_src, az_tgt, el_src, el_tgt)
    for k in range(K):
        ref = xs[k].tolist()
        ref[lay.index("s")] = float(s_new[k])
        turn = (float(az_tgt[k]) - float(az_src[k]) + math.pi) % (2 * math.pi) - math.pi
        ref[lay.index("yaw")] = ref[lay.index("yaw")] + turn
        ref[lay.index("pitch")] = ref[lay.index("pitch")] + (float(el_tgt[k])
                                                             - float(el_src[k]))
        assert got[k].tolist() == ref
        one = moved_state(filt, xs[k], float(s_new[k]),
                          SimpleNamespace(azimuth=az_src[k], elevation=el_src[k]),
                          SimpleNamespace(azimuth=az_tgt[k], elevation=el_tgt[k]))
        assert one.tolist() == ref


def test_the_identity_test_is_allclose_to_the_identity():
    """`_identity` (the mixing's test for a crossing matrix that moves nothing) against
    ``np.allclose(Π, I)``: matrices at, just inside and just outside its tolerances,
    with NaN and inf."""
    rng = np.random.default_rng(22)
    eye = np.eye(5)
    cases = [eye, eye + 5e-9, eye + 2e-8, eye * (1 + 9e-6), eye * (1 + 1.1e-5),
             rng.uniform(0, 1, (5, 5)), np.eye(1)]
    nan, inf = eye.copy(), eye.copy()
    nan[1, 2], inf[3, 3] = np.nan, np.inf
    for T in cases + [nan, inf]:
        assert nw._identity(T) == np.allclose(T, np.eye(T.shape[0]))


def test_abreast_lists_the_others_within_the_radius_the_same_way():
    """`abreast` of five hypotheses at known points: each one's list is the others on
    another element or orientation within the radius whose tangents point the same way
    (written out pair by pair), in index order."""
    filt = SimpleNamespace(layout=SimpleNamespace(names=("yaw", "s", "v")))
    spots = [("A", 1), ("B", 1), ("A", 1), ("C", -1), ("B", 1)]
    hyps = [SimpleNamespace(filt=filt, where=lambda spot=spot: (*spot, 0.0)) for spot in spots]
    r_e = np.array([[0.0, 0.0, 0.0], [4.5, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, -4.0, 0.0],
                    [30.0, 0.0, 0.0]])
    tangent = np.array([[0.0, 1.0, 0.0]] * 3 + [[0.0, -1.0, 0.0], [0.0, 1.0, 0.0]])
    got = nw.abreast(hyps, r_e, tangent, 5.0)
    want = [[j for j in range(5) if spots[j] != spots[i]
             and np.linalg.norm(r_e[i] - r_e[j]) <= 5.0 and tangent[i] @ tangent[j] > 0.0]
            for i in range(5)]
    assert got == want == [[1], [0, 2], [1], [], []]
    assert all(type(j) is int for row in got for j in row)
