"""`Track.at` of one point in Python floats: bit for bit the array path's answer.

A query of one point through the vectorised path (`trackmodel.track.Track` ``_points``:
`trackmodel.loxodrome.loxodrome_position` or `trackmodel.integrated.ChebyshevSections.
position`, `trackmodel.sections.SectionArrays.angles`, `trackmodel.sections.tangent_frame`,
`trackmodel.earth.geodetic_to_ecef`) makes ~200 NumPy calls on arrays of one element, each
~1 µs of call overhead: ~200 µs a point, the cost of the filters' per-epoch track points and
of a projection's Newton steps. This module evaluates the same formulas, operation by
operation in the same order, on Python floats (25-55 µs a point, 4-6x faster: measured
at stop 36 on the shipped tracks). It is a twin of those functions, kept only because it
gives the same bits:

* IEEE arithmetic (``+ − × ÷``, `math.sqrt`) is correctly rounded in both;
* `math.sin` and `math.cos` are the C library's, as NumPy's float64 ``sin``/``cos`` are
  here (equal on 10⁵ random angles; a NumPy with SIMD float64 sine would fail the test);
* NumPy's ``log1p``, ``arctanh`` and ``power`` have SIMD loops of their own (AVX-512:
  ~8 % of ``log1p`` results differ from `math.log1p` in the last bit), so they are called
  here through NumPy on the float (the same loop as an array of one);
* the Gauss–Legendre sums ``(1, 4) @ (4,)`` are NumPy's dot product of the same four
  values (what NumPy makes of a product of one row);
* every branch of a ``np.where`` is the one the array path selects.

``tests/trackmodel/test_one_point.py`` checks every field against the array path on random
``s`` of every section kind (straights on the ellipsoid and the sphere, climbing or not;
arcs, clothoids, vertical curves) and the loxodrome's branches (series and closed forms)
directly. A change to one of the vector functions above must be made here too: that test
fails until it is.
"""
from __future__ import annotations

import bisect
import math

import numpy as np

from trackmodel.loxodrome import _GL_W, _GL_X, _NEWTON_STEPS, _SERIES_X

__all__ = ["point_at"]

_GL_X_LIST = [float(x) for x in _GL_X]
_TWO_PI = 2.0 * np.pi
_EPS = float(np.finfo(float).eps)


def _radii(lat: float, a: float, e2: float, f: float) -> tuple[float, float]:
    """`trackmodel.earth.radii` of one latitude."""
    if f == 0.0:
        N = a + 0.0 * lat
        return N, N
    s = math.sin(lat)
    w2 = 1.0 - e2 * s * s
    N = a / math.sqrt(w2)
    return N * (1.0 - e2) / w2, N


def _gl_sum(values: list[float]) -> float:
    """``values @ _GL_W`` as the array path forms it: NumPy's product of one row of four
    is its dot product of two vectors (the same BLAS ``ddot``)."""
    return float(_GL_W.dot(values))


def _log1p_over_x(x: float) -> float:
    if abs(x) < _SERIES_X:
        return 1.0 - x / 2.0 + x * x / 3.0 - float(np.power(x, 3)) / 4.0 \
            + float(np.power(x, 4)) / 5.0
    return float(np.log1p(x)) / x


def _x_minus_log1p_over_x2(x: float) -> float:
    if abs(x) < _SERIES_X:
        return 0.5 - x / 3.0 + x * x / 4.0 - float(np.power(x, 3)) / 5.0 \
            + float(np.power(x, 4)) / 6.0
    return (x - float(np.log1p(x))) / (x * x)


def _atanh_over_x(x: float) -> float:
    if abs(x) < _SERIES_X:
        return 1.0 + x * x / 3.0 + float(np.power(x, 4)) / 5.0
    return float(np.arctanh(x)) / x


def _divided_atanh_sin(c: float, d: float, s0: float, s1: float, dsin: float) -> float:
    den = 1.0 - c * c * s0 * s1
    x = c * d * dsin / den
    return _atanh_over_x(x) * c * dsin / den


def _divided_isometric(lat0: float, lat1: float, e2: float) -> float:
    e = math.sqrt(e2)
    d = lat1 - lat0
    y = math.pi * (0.5 * d / math.pi)                          # np.sinc's argument
    y = y if y != 0.0 else _EPS
    dsin = math.cos(0.5 * (lat0 + lat1)) * (math.sin(y) / y)
    s0, s1 = math.sin(lat0), math.sin(lat1)
    out = _divided_atanh_sin(1.0, d, s0, s1, dsin)
    if e > 0.0:
        out = out - e * _divided_atanh_sin(e, d, s0, s1, dsin)
    return out


def _node_radii(lat0: float, dlat: float, earth) -> tuple[list, list, list]:
    lat = [lat0 + dlat * x for x in _GL_X_LIST]
    MN = [_radii(v, earth.a_m, earth.e2, earth.f) for v in lat]
    return lat, [m for m, _ in MN], [n for _, n in MN]


def loxodrome_one(lat0: float, lon0: float, h0: float, A: float, E: float, t: float,
                  earth) -> tuple[float, float, float]:
    """`trackmodel.loxodrome.loxodrome_position` of one point (its steps, in order)."""
    a, e2, f = earth.a_m, earth.e2, earth.f
    cE = math.cos(E)
    b, k, q = math.sin(E), math.cos(A) * cE, math.sin(A) * cE
    h = h0 + b * t
    M0, _ = _radii(lat0, a, e2, f)
    P = M0 + h0
    s = math.sin(lat0)
    slope = 3.0 * e2 * M0 * s * math.cos(lat0) / (1.0 - e2 * s * s)
    Q = slope * k / P + b
    x = Q * t / P
    I = (h0 * t * _log1p_over_x(x) + b * t * t * _x_minus_log1p_over_x2(x)) / P
    dm = k * (t - I)
    dlat = dm / M0
    for _ in range(_NEWTON_STEPS):
        Mbar = _gl_sum(_node_radii(lat0, dlat, earth)[1])
        M1, _ = _radii(lat0 + dlat, a, e2, f)
        dlat = dlat - (dlat * Mbar - dm) / M1
    lat_n, M_n, N_n = _node_radii(lat0, dlat, earth)
    Mbar = _gl_sum(M_n)
    lat = lat0 + dlat
    dlon = (t - I) / Mbar * _divided_isometric(lat0, lat, e2)
    if e2 > 0.0:
        bt = b * t
        fn = []
        for la, M, N, x in zip(lat_n, M_n, N_n, _GL_X_LIST):
            hn = h0 + bt * x
            fn.append(hn * (N - M) / (N * (N + hn) * (M + hn) * math.cos(la)))
        dlon = dlon + t * _gl_sum(fn)
    return lat, lon0 + q * dlon, h


def _chebyshev_one(chunks, s: float) -> tuple[float, float, float]:
    """`trackmodel.integrated.ChebyshevSections.position` of one ``s`` (NumPy's
    ``chebval`` recurrence, per component)."""
    j = min(max(bisect.bisect_right(chunks.s0_list, s) - 1, 0), len(chunks.s0_list) - 1)
    x = 2.0 * (s - chunks.s0_list[j]) / chunks.length_list[j] - 1.0
    coef = chunks.coef_lists[j]                       # (CHEB_DEGREE + 1) rows of 3
    x2 = 2 * x
    out = []
    for i, start in enumerate(chunks.start_lists[j]):
        c0, c1 = coef[-2][i], coef[-1][i]
        for row in coef[-3::-1]:
            c0, c1 = row[i] - c1, c0 + c1 * x2
        out.append(start + (c0 + c1 * x))
    return out[0], out[1], out[2]


def _frame(A: float, E: float, dA: float, dE: float, d2A: float) -> tuple[list, list, list]:
    """`trackmodel.sections.tangent_frame` of one point."""
    sA, cA, sE, cE = math.sin(A), math.cos(A), math.sin(E), math.cos(E)
    u = [cE * sA, cE * cA, sE]
    u_A = [cE * cA, -cE * sA, 0.0]
    u_E = [-sE * sA, -sE * cA, cE]
    u_AA = [-cE * sA, -cE * cA, 0.0]
    u_AE = [-sE * cA, sE * sA, 0.0]
    dA2, dAE2, dE2 = dA * dA, 2.0 * dA * dE, dE * dE
    du = [dA * u_A[i] + dE * u_E[i] for i in range(3)]
    d2u = [d2A * u_A[i] + dA2 * u_AA[i] + dAE2 * u_AE[i] - dE2 * u[i] for i in range(3)]
    return u, du, d2u


def _array(value, dtype=float) -> np.ndarray:
    return np.array(value, dtype=dtype)


def point_at(track, s: float) -> dict[str, np.ndarray]:
    """The `trackmodel.TrackPoint` fields of one checked ``s`` (m, a float in
    ``[0, length_m]``), scalars of shape () and vectors of shape (3,): the array path's
    point, bit for bit (module docstring)."""
    rows, earth = track.table_lists, track.earth
    k = track.section_at(s)
    s_start, L, az0, e0, e1, k0, k1, lox = rows[k]
    t = s - s_start
    if lox:
        start = track.start_lists[k]
        lat, lon, h = loxodrome_one(start[0], start[1], start[2], az0, e0, t, earth)
    else:
        lat, lon, h = _chebyshev_one(track._chunks.lists, s)
    d2A = (k1 - k0) / L                                         # SectionArrays.angles
    A = (az0 + k0 * t + 0.5 * d2A * t * t) % _TWO_PI
    dE = (e1 - e0) / L
    dA, E = k0 + d2A * t, e0 + dE * t
    u, du, d2u = _frame(A, E, dA, dE, d2A)
    _, N = _radii(lat, earth.a_m, earth.e2, earth.f)           # geodetic_to_ecef
    cl = math.cos(lat)
    r_e = [(N + h) * cl * math.cos(lon), (N + h) * cl * math.sin(lon),
           (N * (1.0 - earth.e2) + h) * math.sin(lat)]
    return dict(s=_array(s), lat=_array(lat), lon=_array(lon), h=_array(h), r_e=_array(r_e),
                u_n=_array(u), du_ds_n=_array(du), d2u_ds2_n=_array(d2u), azimuth=_array(A),
                elevation=_array(E), curvature_1pm=_array(dA), elevation_rate=_array(dE),
                section=_array(k, np.intp))
