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
