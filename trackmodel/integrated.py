"""Curved sections (arcs, clothoids, vertical curves): integrated once, stored as Chebyshev series.

A section whose azimuth or elevation varies has no closed form on the ellipsoid. When the
`Track` is built, each such section is integrated once with ``scipy.integrate.solve_ivp``
(DOP853, rtol 1e-13) for the geodetic offsets from its start::

    dφ/dt = cosϑ cosA / (M + h),   dλ/dt = cosϑ sinA / ((N + h) cosφ),   dh/dt = sinϑ

and the dense solution is sampled on Chebyshev nodes of short chunks (at most
`CHUNK_MAX_M` long and turning at most `CHUNK_MAX_TURN_RAD`) and stored as Chebyshev
series of degree `CHEB_DEGREE`. A query is then a vectorised Clenshaw evaluation. At build
the series are checked against the dense solution between the nodes; a chunk whose error
exceeds `CHEB_CHECK_RAD` (≈ 6 µm on the Earth) is split.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from functools import cached_property
from types import SimpleNamespace

import numpy as np
import numpy.polynomial.chebyshev as cheb
import numpy.typing as npt

from trackmodel.earth import Ellipsoid
from trackmodel.sections import SectionArrays

log = logging.getLogger(__name__)

__all__ = ["ChebyshevSections", "integrate_section"]

Array = npt.NDArray[np.float64]

CHEB_DEGREE = 16
CHUNK_MAX_M = 1000.0
CHUNK_MAX_TURN_RAD = 0.25
#: Acceptance of a series against the dense ODE solution, rad (1e-12 rad = 6 µm).
CHEB_CHECK_RAD = 1e-12
#: ODE tolerances: relative, and absolute for (Δφ, Δλ) rad and Δh m.
ODE_RTOL = 1e-13
ODE_ATOL = (1e-15, 1e-15, 1e-10)
_MAX_SPLITS = 6


@dataclass(frozen=True)
class ChebyshevSections:
    """Chebyshev chunks of all integrated sections of a track.

    Attributes
    ----------
    s0, length : ndarray, shape (C,)
        Global along-track start and length of each chunk, m (sorted by ``s0``).
    coef : ndarray, shape (CHEB_DEGREE + 1, C, 3)
        Series of (Δφ rad, Δλ rad, Δh m), offsets from the chunk start, in ``x ∈ [-1, 1]``.
    start : ndarray, shape (C, 3)
        Geodetic (φ rad, λ rad, h m) at each chunk start.
    """

    s0: Array
    length: Array
    coef: Array
    start: Array

    @classmethod
    def stack(cls, chunks: list[tuple[float, float, Array, Array]]) -> "ChebyshevSections":
        """Assemble chunks from `integrate_section` (in increasing ``s``)."""
        s0, length, coef, start = zip(*chunks)
        return cls(np.array(s0), np.array(length), np.stack(coef, axis=1), np.array(start))

    @cached_property
    def lists(self) -> SimpleNamespace:
        """The chunks as Python lists (`trackmodel.one_point`): ``s0_list``,
        ``length_list``, ``coef_lists[j]`` (CHEB_DEGREE + 1 rows of 3) and ``start_lists[j]``."""
        return SimpleNamespace(s0_list=self.s0.tolist(), length_list=self.length.tolist(),
                               coef_lists=self.coef.transpose(1, 0, 2).tolist(),
                               start_lists=self.start.tolist())

    def position(self, s: Array) -> tuple[Array, Array, Array]:
        """Geodetic position at global ``s`` (m, shape (N,)) inside integrated sections."""
        j = np.clip(np.searchsorted(self.s0, s, side="right") - 1, 0, len(self.s0) - 1)
        x = 2.0 * (s - self.s0[j]) / self.length[j] - 1.0
        d = cheb.chebval(x[:, None], self.coef[:, j, :], tensor=False)
        out = self.start[j] + d
        return out[:, 0], out[:, 1], out[:, 2]


def _rhs(sec: SectionArrays, k: int, start: Array, earth: Ellipsoid):
    """Right-hand side in plain floats (it is called thousands of times per section)."""
    A0, k0 = float(sec.azimuth0[k]), float(sec.curvature0[k])
    half_d2A = 0.5 * (float(sec.curvature1[k]) - k0) / float(sec.length[k])
    E0 = float(sec.elevation0[k])
    dE = (float(sec.elevation1[k]) - E0) / float(sec.length[k])
    lat0, h0 = float(start[0]), float(start[2])
    a, e2 = earth.a_m, earth.e2

    def f(t: float, y: Array) -> Array:
        A = A0 + t * (k0 + half_d2A * t)
        E = E0 + dE * t
        lat, h = lat0 + y[0], h0 + y[2]
        sl = math.sin(lat)
        w2 = 1.0 - e2 * sl * sl
        N = a / math.sqrt(w2)
        M = N * (1.0 - e2) / w2
        cE = math.cos(E)
        return np.array([cE * math.cos(A) / (M + h),
                         cE * math.sin(A) / ((N + h) * math.cos(lat)),
                         math.sin(E)])
    return f


def _chunk_edges(sec: SectionArrays, k: int) -> Array:
    L = sec.length[k]
    turn = 0.5 * L * (abs(sec.curvature0[k]) + abs(sec.curvature1[k]))
    n = max(1, math.ceil(L / CHUNK_MAX_M), math.ceil(turn / CHUNK_MAX_TURN_RAD))
    return np.linspace(0.0, L, n + 1)


def _fit_chunk(dense, a: float, b: float) -> tuple[Array, float]:
    """Chebyshev series of the offsets over [a, b] and its worst error between nodes."""
    n = CHEB_DEGREE + 1
    x = np.cos(np.pi * (np.arange(n) + 0.5) / n)
    ya = dense(a)
    y = dense(a + 0.5 * (x + 1.0) * (b - a)).T - ya
    c = cheb.chebfit(x, y, CHEB_DEGREE)
    xm = np.cos(np.pi * np.arange(1, n) / n)                 # between the nodes
    ym = dense(a + 0.5 * (xm + 1.0) * (b - a)).T - ya
    err = np.abs(cheb.chebval(xm, c).T - ym)[:, :2].max()
    return c, float(err)


def integrate_section(sec: SectionArrays, k: int, start: Array,
                      earth: Ellipsoid) -> tuple[list[tuple[float, float, Array, Array]], Array]:
    """Integrate section `k` from its start point.

    Parameters
    ----------
    sec : SectionArrays
    k : int
        Section index.
    start : ndarray, shape (3,)
        Geodetic start (φ rad, λ rad, h m).
    earth : Ellipsoid

    Returns
    -------
    chunks : list of (s0 m, length m, coef (CHEB_DEGREE + 1, 3), start (3,))
        The section's Chebyshev chunks, for `ChebyshevSections.stack`.
    end : ndarray, shape (3,)
        Geodetic position at the section end (from the ODE solution).
    """
    from scipy.integrate import solve_ivp   # only tracks with curves (~0.2 s, ~25 MB)
    sol = solve_ivp(_rhs(sec, k, start, earth), (0.0, float(sec.length[k])), np.zeros(3),
                    method="DOP853", rtol=ODE_RTOL, atol=ODE_ATOL, dense_output=True)
    edges = _chunk_edges(sec, k)
    pending = list(zip(edges[:-1], edges[1:]))
    chunks = []
    while pending:
        a, b = pending.pop(0)
        c, err = _fit_chunk(sol.sol, a, b)
        if err > CHEB_CHECK_RAD and (b - a) > sec.length[k] / 2 ** _MAX_SPLITS:
            m = 0.5 * (a + b)
            pending[:0] = [(a, m), (m, b)]
            continue
        if err > CHEB_CHECK_RAD:
            log.warning("section %d: Chebyshev error %.2g rad above %.2g", k, err,
                        CHEB_CHECK_RAD)
        chunks.append((sec.s_start[k] + a, b - a, c, start + sol.sol(a)))
    return chunks, start + sol.y[:, -1]
