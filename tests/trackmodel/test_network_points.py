"""Points on several tracks at once (`trackmodel.network_points.points_on`).

Reference: `trackmodel.track.Track.at` of each track alone, point by point. The stacked
evaluation must give the same numbers bit for bit (the network navigator's outputs must not
change by using it): on integrated (Chebyshev) and straight (loxodrome) sections, on
reversed tracks, at the ends, with several points on one track and with tracks on two
ellipsoids (curvy and double_a on WGS-84, paper2017 on a sphere).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from trackmodel.io import read_track
from trackmodel.network_lines import reversed_track
from trackmodel.network_points import points_on
from trackmodel.offset import offset_track

TRACKS = Path(__file__).resolve().parents[2] / "data" / "tracks"
FIELDS = ("s", "lat", "lon", "h", "r_e", "u_n", "azimuth", "elevation")


@pytest.fixture(scope="module")
def tracks():
    out = []
    for name in ("curvy", "double_a", "paper2017"):
        base = read_track(TRACKS / f"{name}.csv")
        out += [base, offset_track(base, 4.5), reversed_track(base)]
    return out


def _same(track, s: float, point) -> list[str]:
    ref = track.at(s)
    return [f for f in FIELDS
            if not np.array_equal(np.asarray(getattr(ref, f)), np.asarray(getattr(point, f)))]


def test_points_on_equal_track_at_bit_for_bit(tracks):
    rng = np.random.default_rng(7)
    for _ in range(20):
        pick = [tracks[k] for k in rng.integers(0, len(tracks), 10)]
        s = [float(rng.choice([0.0, t.length_m])) if rng.random() < 0.2
             else float(rng.uniform(0.0, t.length_m)) for t in pick]
        for t, sk, p in zip(pick, s, points_on(pick, s)):
            assert _same(t, sk, p) == [], (sk, t.length_m)


def test_points_on_repeats_and_the_same_track_twice(tracks):
    t = tracks[0]
    s = [10.0, 2500.5, 10.0]
    first = points_on([t, tracks[1], t], s)
    again = points_on([t, tracks[1], t], s)          # from the kept stack
    for p, q, sk, tk in zip(first, again, s, [t, tracks[1], t]):
        assert _same(tk, sk, p) == [] and _same(tk, sk, q) == []


def test_points_on_refuses_s_off_the_track(tracks):
    from trackmodel.errors import TrackError
    with pytest.raises(TrackError):
        points_on([tracks[0]], [tracks[0].length_m + 100.0])


def test_points_on_at_every_joint_and_chunk_start_together(tracks):
    """Points exactly at each section joint and each Chebyshev chunk start (where the
    search of `TrackStack` over all tracks' tables at once must pick the section and chunk
    that `Track.at` picks in the track's own table), on all nine tracks in one call."""
    pick, s = [], []
    for t in tracks:
        spots = list(t.table.s_start) + ([] if t._chunks is None else list(t._chunks.s0))
        spots += [min(x + 1e-9, t.length_m) for x in spots] + [t.length_m]
        pick += [t] * len(spots)
        s += [float(x) for x in spots]
    assert any(t._chunks is not None for t in tracks)
    for t, sk, p in zip(pick, s, points_on(pick, s)):
        assert _same(t, sk, p) == [], (sk, t.length_m)


def test_points_on_names_the_track_off_which_s_lies(tracks):
    from trackmodel.errors import TrackError
    with pytest.raises(TrackError, match=f"<= {tracks[3].length_m!r} m"):
        points_on([tracks[0], tracks[3], tracks[3]], [1.0, 2.0, tracks[3].length_m + 5.0])
    with pytest.raises(TrackError, match="finite"):
        points_on([tracks[0], tracks[3]], [1.0, float("nan")])


def test_points_without_positions_have_the_same_angles(tracks):
    """``positions=False``: the tangent and the angles of `Track.at`, bit for bit, and no
    position (asking for one is an AttributeError, not a made-up number)."""
    rng = np.random.default_rng(8)
    pick = [tracks[k] for k in rng.integers(0, len(tracks), 12)]
    s = [float(rng.uniform(0.0, t.length_m)) for t in pick]
    for t, sk, p in zip(pick, s, points_on(pick, s, positions=False)):
        ref = t.at(sk)
        for f in ("s", "u_n", "azimuth", "elevation"):
            assert np.array_equal(np.asarray(getattr(ref, f)), np.asarray(getattr(p, f))), f
        with pytest.raises(AttributeError):
            p.lat


def _ecef(points):
    """ECEF positions and unit tangents ``C_n_e u_n`` of `Track.at` points, (K, 3)."""
    from trackmodel.earth import C_n_e
    r = np.array([np.asarray(p.r_e, dtype=float).reshape(3) for p in points])
    return r, np.array([np.asarray(C_n_e(p.lat, p.lon)).reshape(3, 3)
                        @ np.asarray(p.u_n).reshape(3) for p in points])


def test_node_points_are_the_tracks_points_within_their_expansion_error(tracks):
    """`NodePoints` against `Track.at` point by point (ECEF position and unit tangent):
    within the module docstring's bounds of the second-order expansion from nodes 1 m
    apart, ``δ ≤ 0.5 m``. Away from section joints (random distances on all nine tracks:
    curvy's transitions and curves, double_a, a sphere): the local frame's turn over δ,
    at most ``θ = δ/(R cos φ)`` (R ≥ 6.3e6 m; position ``θ δ/2``, tangent ``θ``), plus
    the third-order term (position ``|d²u/ds²| δ³/6``, tangent ``|d²u/ds²| δ²/2``, the
    track's largest ``|d²u/ds²|`` from `Track.at`). Within a node of a joint, where
    ``du/ds`` may change its rate or jump, also ``|Δ du/ds| δ²/2`` and ``|Δ du/ds| δ``
    (the jump read from `Track.at` either side of the joint). The same points asked for
    again (from the blocks kept) give the same numbers; ``s`` off the track is clamped."""
    from trackmodel.network_points import NodePoints
    rng = np.random.default_rng(9)
    nodes = NodePoints()
    for t in tracks:
        joints = t.table.s_start[1:]
        s = rng.uniform(0.0, t.length_m, 60)
        if joints.size:
            s = s[np.min(np.abs(s[:, None] - joints[None, :]), axis=1) > 1.0]
        d, radius_m = 0.5, 6.3e6
        along = t.at(np.linspace(0.0, t.length_m, 20001))
        d2u = np.max(np.linalg.norm(along.d2u_ds2_n, axis=-1))
        turn = d / (radius_m * np.min(np.cos(along.lat)))      # the ENU frame's, rad
        bound_r = turn * d / 2 + d2u * d ** 3 / 6 + 1e-9
        bound_t = turn + d2u * d * d / 2 + 1e-9
        r, tangent = nodes.ecef([t] * s.size, s)
        r_ref, t_ref = _ecef([t.at(float(x)) for x in s])
        assert np.max(np.linalg.norm(r - r_ref, axis=1)) < bound_r
        assert np.max(np.linalg.norm(tangent - t_ref, axis=1)) < bound_t
        near = np.concatenate([joints - 0.4, joints + 0.4, [0.0, t.length_m]])
        r, tangent = nodes.ecef([t] * near.size, near)
        r_ref, t_ref = _ecef([t.at(float(x)) for x in near])
        before, after = t.at(np.maximum(joints - 1e-6, 0.0)), t.at(joints + 1e-6)
        jump = np.max(np.linalg.norm(np.asarray(after.du_ds_n) - np.asarray(before.du_ds_n),
                                     axis=-1), initial=0.0)
        assert np.max(np.linalg.norm(r - r_ref, axis=1)) < jump * d * d / 2 + bound_r
        assert np.max(np.linalg.norm(tangent - t_ref, axis=1)) < jump * d + bound_t
        again, _ = nodes.ecef([t] * near.size, near)
        assert np.array_equal(again, r)
    t = tracks[0]
    outside, _ = nodes.ecef([t, t], [-3.0, t.length_m + 3.0])
    assert np.array_equal(outside, nodes.ecef([t, t], [0.0, t.length_m])[0])


def test_point_fields_are_each_points_own(tracks):
    """`point_fields` against ``getattr`` point by point: the fields of one `points_on`
    call (read by one index), of points from two calls and of `Track.at` points (point
    by point), bit for bit; a field not evaluated raises AttributeError."""
    from trackmodel.network_points import point_fields
    rng = np.random.default_rng(12)
    pick = [tracks[k] for k in rng.integers(0, len(tracks), 9)]
    s = [float(rng.uniform(0.0, t.length_m)) for t in pick]
    one = points_on(pick, s)
    mixed = one[:4] + points_on(pick[4:], s[4:])
    scalar = [t.at(x) for t, x in zip(pick, s)]
    for points in (one, one[::-2], mixed, scalar):
        found = point_fields(points, *FIELDS)
        for name, values in zip(FIELDS, found):
            ref = np.array([np.asarray(getattr(p, name), dtype=float) for p in points])
            np.testing.assert_array_equal(values, ref)
    with pytest.raises(AttributeError, match="not evaluated"):
        point_fields(points_on(pick, s, positions=False), "lat")


def test_node_points_are_found_as_point_by_point(tracks):
    """`NodePoints.ecef` finds the nodes of all points at once: the same numbers as the
    point-by-point rule (``round(s)`` half to even, clamped to the track's last node,
    ``δ = s − s_node``) expanded from the same node rows, at half-metre ties too."""
    import math

    from trackmodel.network_points import BLOCK_NODES, NODE_STEP_M, NodePoints, \
        expanded_points
    rng = np.random.default_rng(13)
    nodes = NodePoints()
    pick = [tracks[k] for k in rng.integers(0, len(tracks), 12)]
    s = [float(rng.uniform(-1.0, t.length_m + 1.0)) for t in pick]
    s[:3] = [2.5, 3.5, pick[2].length_m - 0.25]                 # ties and the end
    r, tangent = nodes.ecef(pick, s)
    rows, d = [], []
    for t, x in zip(pick, s):
        x = min(max(x, 0.0), t.length_m)
        node = min(int(round(x / NODE_STEP_M)), int(math.ceil(t.length_m / NODE_STEP_M)))
        block, row = divmod(node, BLOCK_NODES)
        rows.append(nodes._rows(t, block)[row])
        d.append(x - min(node * NODE_STEP_M, t.length_m))
    tab = np.array(rows)
    C = tab[:, 3:12].reshape(-1, 3, 3)
    r_ref, u_ref = expanded_points(tab[:, :3], C, tab[:, 12:15], tab[:, 15:18], np.array(d))
    np.testing.assert_array_equal(r, r_ref)
    np.testing.assert_array_equal(tangent, np.einsum("kij,kj->ki", C, u_ref))
    with pytest.raises(ValueError, match="not finite"):
        nodes.ecef(pick[:1], [float("nan")])
