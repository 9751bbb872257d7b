"""`trackmodel.one_point`: one track point in Python floats gives the same bits as the
vectorised path of an array of one point (`Track._points`), which is what every one-point
query computed before it; on every section kind, on the ellipsoid and the sphere, and on
the loxodrome's series and closed-form branches."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

# (tests import submodules: under pytest, tests/trackmodel shadows the package name)
from trackmodel.earth import WGS84, sphere
from trackmodel.errors import TrackError
from trackmodel.io import read_track
from trackmodel.loxodrome import _SERIES_X, loxodrome_position
from trackmodel.one_point import loxodrome_one, point_at
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

TRACKS = Path(__file__).resolve().parents[2] / "data" / "tracks"
R_M = 800.0
#: Every section kind: straights flat and climbing (loxodromes), a clothoid in, an arc,
#: a clothoid out, a vertical curve, an arc on a grade, a street corner.
ALL_KINDS = [Section(3000.0, 30.0, 0.5), Section(2500.0, None, 0.0),
             Section(150.0, None, None, 0.0, 1 / R_M, 1.0),
             Section(1200.0, None, None, 1 / R_M), Section(150.0, None, None, 1 / R_M, 0.0),
             Section(5000.0, None, 1.0, elevation_end_deg=-1.0),
             Section(900.0, None, -1.0, -1 / 600.0), Section(400.0, None, None, 0.0, -1 / 20.0),
             Section(4000.0, None, 2.5)]


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return (a.shape == b.shape and a.dtype == b.dtype
            and a.tobytes() == b.tobytes())      # the bits, signed zeros included


def _assert_point_bits(track: Track, s_values) -> None:
    for s in s_values:
        vec = track._points(np.array([s]))
        one = point_at(track, track._check_one(s))
        assert one.keys() == vars(vec).keys()
        for name, value in vars(vec).items():
            assert _same_bits(one[name], value[0]), (name, s)


def _samples(track: Track, per_section: int, seed: int) -> list[float]:
    """Random s in every section, and its ends and joints."""
    rng = np.random.default_rng(seed)
    tab = track.table
    s = [tab.s_start[k] + rng.uniform(0.0, tab.length[k], per_section)
         for k in range(len(track.sections))]
    return [float(v) for v in np.concatenate([*s, tab.s_start, [track.length_m]])]


@pytest.mark.parametrize("earth", [WGS84, sphere()], ids=["wgs84", "sphere"])
@pytest.mark.parametrize("origin", [Origin(41.6, 2.35, 250.0), Origin(-62.0, -70.0, 2400.0),
                                    Origin(0.001, 179.9, -20.0)], ids=["north", "south", "equator"])
def test_every_section_kind_gives_the_array_paths_bits(earth, origin):
    track = Track(ALL_KINDS, origin, earth)
    assert track.table.is_loxodrome.any() and not track.table.is_loxodrome.all()
    _assert_point_bits(track, _samples(track, 60, seed=1))


@pytest.mark.parametrize("name", ["paper2017", "curvy", "east_west", "barcelona_drive"])
def test_shipped_tracks_give_the_array_paths_bits(name):
    track = read_track(TRACKS / f"{name}.csv")
    _assert_point_bits(track, _samples(track, max(5, 600 // len(track.sections)), seed=2))


def test_loxodrome_branches_give_the_array_paths_bits():
    """Parameters far beyond a track's (long steep straights, ~1000 km), so that both the
    series (|x| < `_SERIES_X`) and the closed forms of each divided difference are taken."""
    rng = np.random.default_rng(3)
    n = 3000
    lat0, lon0 = rng.uniform(-1.3, 1.3, n), rng.uniform(-3.1, 3.1, n)
    h0 = rng.uniform(-400.0, 5000.0, n)
    A, E = rng.uniform(0.0, 2.0 * np.pi, n), rng.uniform(-0.4, 0.4, n)
    t = rng.choice([-1.0, 1.0], n) * 10.0 ** rng.uniform(-3.0, 6.0, n)
    large_x = 0
    for earth in (WGS84, sphere()):
        for i in range(n):
            args = (lat0[i], lon0[i], h0[i], A[i], E[i], t[i])
            vec = loxodrome_position(*(np.array([v]) for v in args[:3]), azimuth=np.array([A[i]]),
                                     elevation=np.array([E[i]]), t=np.array([t[i]]),
                                     earth=earth)
            one = loxodrome_one(*args, earth)
            for a, b in zip(one, vec):
                assert _same_bits(np.float64(a), b[0]), (earth.name, args)
            large_x += abs(np.sin(E[i]) * t[i] / earth.a_m) >= _SERIES_X
    assert large_x > 100                      # the closed form of log1p(x)/x was taken


def test_one_point_queries_keep_their_shapes_and_errors():
    track = Track(ALL_KINDS, Origin(41.6, 2.35, 250.0), WGS84)
    s = 3456.7
    scalar, one, column = track.at(s), track.at(np.array([s])), track.at(np.array([[s]]))
    assert scalar.lat.shape == () and scalar.r_e.shape == (3,)
    assert not scalar.r_e.flags.writeable                     # kept for a repeated query
    assert one.lat.shape == (1,) and one.u_n.shape == (1, 3) and one.u_n.flags.writeable
    assert column.h.shape == (1, 1) and column.d2u_ds2_n.shape == (1, 1, 3)
    assert scalar.section.dtype == np.intp and scalar.section == track.section_of(np.array([s]))[0]
    assert track.at(-1e-7).s == 0.0 and track.at(track.length_m + 1e-7).s == track.length_m
    for bad in (np.nan, -1.0, track.length_m + 1.0):
        with pytest.raises(TrackError) as one_error:
            track.at(bad)
        with pytest.raises(TrackError) as array_error:
            track.at(np.array([bad, 1.0]))
        assert str(one_error.value).split(",")[0] == str(array_error.value).split(",")[0]


def test_projection_carries_the_track_point_at_its_s():
    track = read_track(TRACKS / "curvy.csv")
    s = np.linspace(100.0, track.length_m - 100.0, 7)
    lat, lon, _ = track.geodetic(s)
    for part in (slice(0, 1), slice(None)):
        proj = track.project(lat[part] + 2e-6, lon[part] - 1e-6)
        again = track.at(proj.s)
        for name, value in vars(again).items():
            assert _same_bits(getattr(proj.point, name), value), name
        assert list(proj.to_frame().columns) == ["s_m", "cross_track_m", "vertical_m",
                                                 "along_m", "distance_m"]


def test_each_step_gives_the_vector_functions_bits():
    """The steps one by one on values spread over their whole ranges (the series and the
    closed forms alike): a last-bit difference inside may be rounded away in the position,
    so the steps are compared too."""
    from trackmodel import loxodrome as vec
    from trackmodel import one_point as one
    from trackmodel.earth import radii
    from trackmodel.sections import tangent_frame
    rng = np.random.default_rng(4)
    x = rng.choice([-1.0, 1.0], 4000) * 10.0 ** rng.uniform(-9.0, -0.05, 4000)
    for name in ("_log1p_over_x", "_x_minus_log1p_over_x2", "_atanh_over_x"):
        want = getattr(vec, name)(x)
        assert all(_same_bits(np.float64(getattr(one, name)(float(v))), w)
                   for v, w in zip(x, want)), name
    lat0, dlat = rng.uniform(-1.4, 1.4, 2000), x[:2000] * 0.5
    for earth in (WGS84, sphere()):
        want = vec._divided_isometric(lat0, lat0 + dlat, earth)
        M, N = radii(lat0, earth=earth)
        for i in range(lat0.size):
            assert _same_bits(np.float64(one._divided_isometric(lat0[i], lat0[i] + dlat[i],
                                                                earth.e2)), want[i])
            assert one._radii(lat0[i], earth.a_m, earth.e2, earth.f) == (M[i], N[i])
    A, E = rng.uniform(-7.0, 7.0, (2, 500))
    dA, dE, d2A = rng.normal(0.0, 1e-2, (3, 500))
    frames = tangent_frame(A, E, dA, dE, d2A)
    for i in range(A.size):
        for got, want in zip(one._frame(A[i], E[i], dA[i], dE[i], d2A[i]), frames):
            assert _same_bits(np.array(got), want[i])
