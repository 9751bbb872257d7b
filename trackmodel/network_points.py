"""Points on several tracks at once: `points_on` (the network navigator's hypotheses).

A bank of hypotheses asks, every cycle, for one or two points on each of K tracks (the
netelements or chained routes they are on). `trackmodel.track.Track.at` evaluates one
track per call, about a hundred small NumPy operations whatever the number of points:
K tracks cost K times that. `points_on` does the per-track part only where it must
(validating ``s``, finding its section and, on integrated sections, its Chebyshev chunk)
and everything else once for all the points: the loxodrome positions, the section
angles, the tangent frame and the ECEF positions, over the section tables of the K tracks
stacked (`TrackStack`, kept for the next cycle asking for the same tracks). The arithmetic
of each point is `Track.at`'s, element by element: the same numbers
(`tests/trackmodel/test_network_points.py` compares them bit for bit).

`NodePoints` is cheaper still where a point's position and tangent are wanted to a
micrometre rather than to the bit (the network navigator's spawn test, every epoch):
each track is evaluated once on nodes every `NODE_STEP_M`, a block of `BLOCK_NODES` at
a time when a point first needs them, and a point is its nearest node expanded to second
order in ``δ = s − s_node`` (`expanded_points`; ``|δ| ≤ NODE_STEP_M/2``). What the
expansion leaves: the third-order term ``|d²u/ds²| δ³/6`` (``|d²u/ds²| ≲ |dκ/ds| + κ²
≈ 1.4e-5 m⁻²`` for a 600-m curve entered by a 120-m transition: 3e-7 m; the tangent
``|d²u/ds²| δ²/2``, 1.8e-6) and the turn of the local frame over ``δ``, ``θ ≤ δ/(R cos φ)``
(1.2e-7 rad at 50°; the position ``θ δ/2``, 3e-8 m). A node across a section joint where
``du/ds`` jumps by ``Δ`` adds ``Δ δ²/2`` to the position and ``Δ δ`` to the tangent: on
the shipped tracks (grade and curvature-rate changes) up to ~1e-5 m and 4e-5; a curve of
radius ρ meeting a straight without a transition, ``δ²/(2ρ)`` (4e-4 m for ρ = 300 m).
"""
from __future__ import annotations

import math

import numpy as np
import numpy.polynomial.chebyshev as cheb
import numpy.typing as npt

from trackmodel.earth import C_n_e, geodetic_to_ecef
from trackmodel.loxodrome import loxodrome_position
from trackmodel.sections import SectionArrays, tangent_frame
from trackmodel.track import S_TOLERANCE_M

__all__ = ["points_on", "point_fields", "TrackStack", "StackPoint", "NodePoints",
           "expanded_points", "NODE_STEP_M"]

Array = npt.NDArray[np.float64]

#: Stacks of tracks kept (then forgotten together).
MAX_STACKS = 64
#: Node spacing of `NodePoints`, m.
NODE_STEP_M = 1.0
#: Nodes `NodePoints` evaluates in one `Track.at` call: 1 km of track, ~1.5 ms of CPU
#: (~30 µs per second of a train at 20 m/s).
BLOCK_NODES = 1024
#: Blocks `NodePoints` keeps (then forgets together), 150 kB each.
MAX_BLOCKS = 256

_STACKS: dict[tuple[int, ...], "TrackStack"] = {}


class StackPoint:
    """One point of `points_on`: the fields of `trackmodel.track.TrackPoint` the
    navigator uses (scalars; vectors of 3), read from the call's arrays when asked for
    (a bank's cycle asks for a few fields of a few of the points it evaluates)."""

    FIELDS = ("s", "lat", "lon", "h", "r_e", "u_n", "azimuth", "elevation")
    __slots__ = ("_values", "_m")

    def __init__(self, values: dict, m: int) -> None:
        self._values, self._m = values, m

    def __getattr__(self, name: str):
        if name not in StackPoint.FIELDS:
            raise AttributeError(name)
        try:
            return self._values[name][self._m]
        except KeyError:
            raise AttributeError(f"{name}: not evaluated (points_on(positions=False))") \
                from None


def point_fields(points, *names: str) -> tuple[Array, ...]:
    """Fields `names` of each point stacked, each shape (N,) or (N, 3): ``np.array([
    getattr(p, name) for p in points], dtype=float)`` for each name, read from the call's
    own arrays at once (one fancy index each: the same numbers) when the points are
    `StackPoint` objects of one `points_on` call."""
    first = points[0] if len(points) else None
    if type(first) is StackPoint:
        values = first._values
        if all(type(p) is StackPoint and p._values is values for p in points):
            at = [p._m for p in points]
            try:
                return tuple(np.array(values[name][at], dtype=float) for name in names)
            except KeyError:
                raise AttributeError(f"{names}: not evaluated (points_on(positions=False))") \
                    from None
    return tuple(np.array([np.asarray(getattr(p, name), dtype=float) for p in points],
                          dtype=float) for name in names)


def _keys(groups) -> npt.NDArray[np.complex128]:
    """``m + i·s`` of each group's sorted distances `s` (m the group's index): complex
    numbers sort lexicographically (real part, then imaginary), so one `np.searchsorted`
    on the groups' keys concatenated finds a distance within its own group, by the same
    float comparisons as a search in that group alone."""
    return np.concatenate([_key(np.full(len(g), float(m)), np.asarray(g, dtype=float))
                           for m, g in enumerate(groups)])


def _key(m: Array, s: Array) -> npt.NDArray[np.complex128]:
    out = np.empty(s.shape, dtype=np.complex128)
    out.real, out.imag = m, s
    return out


class TrackStack:
    """The section tables of several tracks, stacked (module docstring).

    Parameters
    ----------
    tracks : sequence of trackmodel.track.Track
        On one ellipsoid.

    Notes
    -----
    Reads the tracks' section tables and section starts (``table``, ``starts``) and their
    Chebyshev chunks (``Track._chunks``: ``s0``, ``length``, ``coef``, ``start``, stacked as
    the sections are) for positions on integrated sections.
    """

    def __init__(self, tracks) -> None:
        self.tracks = tuple(tracks)
        self.earth = self.tracks[0].earth
        tables = [t.table for t in self.tracks]
        counts = np.array([len(t.sections) for t in self.tracks])
        self.first = np.cumsum(np.concatenate([[0], counts]))[:-1]
        self.last = self.first + counts - 1
        self.lengths = np.array([t.length_m for t in self.tracks])
        self.table = SectionArrays(*(np.concatenate([getattr(tab, name) for tab in tables])
                                     for name in ("s_start", "length", "azimuth0",
                                                  "elevation0", "elevation1", "curvature0",
                                                  "curvature1")))
        self.starts = np.concatenate([t.starts[:-1] for t in self.tracks])
        self.is_loxodrome = self.table.is_loxodrome
        self._section_keys = _keys([tab.s_start for tab in tables])
        chunks = [t._chunks for t in self.tracks]
        sizes = np.array([0 if c is None else len(c.s0) for c in chunks])
        self._chunk_first = np.cumsum(np.concatenate([[0], sizes]))[:-1]
        self._chunk_last = self._chunk_first + sizes - 1
        have = [c for c in chunks if c is not None]
        self._chunk_keys = _keys([[] if c is None else c.s0 for c in chunks])
        if have:
            self._chunk_s0 = np.concatenate([c.s0 for c in have])
            self._chunk_length = np.concatenate([c.length for c in have])
            self._chunk_coef = np.concatenate([c.coef for c in have], axis=1)
            self._chunk_start = np.concatenate([c.start for c in have])

    def _checked(self, which: npt.NDArray[np.intp], s: list[float]) -> Array:
        """``s`` clamped to each point's track, as `trackmodel.track.Track.check_s` does
        (out of a track, its own error, tracks taken in order)."""
        flat = np.array(s, dtype=float)
        length = self.lengths[which]
        if not (np.all(np.isfinite(flat)) and np.all(flat >= -S_TOLERANCE_M)
                and np.all(flat <= length + S_TOLERANCE_M)):
            for m in sorted(set(which.tolist())):
                self.tracks[m].check_s(flat[which == m])
        return np.clip(flat, 0.0, length)

    def _chunk_positions(self, which: npt.NDArray[np.intp], s: Array
                         ) -> tuple[Array, Array, Array]:
        """`trackmodel.integrated.ChebyshevSections.position` of each point on its track's
        chunks, all at once (the chunk found in its track's alone; the series evaluated
        element by element)."""
        pos = np.searchsorted(self._chunk_keys, _key(which.astype(float), s), side="right")
        first = self._chunk_first[which]
        j = np.clip(pos - 1 - first, 0, self._chunk_last[which] - first) + first
        x = 2.0 * (s - self._chunk_s0[j]) / self._chunk_length[j] - 1.0
        d = cheb.chebval(x[:, None], self._chunk_coef[:, j, :], tensor=False)
        out = self._chunk_start[j] + d
        return out[:, 0], out[:, 1], out[:, 2]

    def points(self, which: list[int], s: list[float], *, positions: bool = True
               ) -> dict[str, Array]:
        """Fields (`StackPoint`) at ``s[k]`` on track ``which[k]``, shape (N,) or (N, 3);
        without `positions`, only ``s``, ``u_n``, ``azimuth`` and ``elevation`` (the
        section angles, without the positions' geodesy)."""
        which_a = np.asarray(which, dtype=np.intp)
        flat = self._checked(which_a, s)
        # each point's section in its own track's table (`Track.section_of`), all at once
        pos = np.searchsorted(self._section_keys, _key(which_a.astype(float), flat),
                              side="right")
        first = self.first[which_a]
        k = np.clip(pos - 1 - first, 0, self.last[which_a] - first) + first
        ang = self.table.angles(k, flat - self.table.s_start[k])
        u, _, _ = tangent_frame(ang["A"], ang["E"], ang["dA"], ang["dE"], ang["d2A"],
                                derivatives=False)
        out = {"s": flat, "u_n": u, "azimuth": ang["A"], "elevation": ang["E"]}
        if not positions:
            return out
        lat, lon, h = np.empty(len(s)), np.empty(len(s)), np.empty(len(s))
        lox = self.is_loxodrome[k]
        if lox.any():                                     # all tracks' straights at once
            kl, tab = k[lox], self.table
            lat[lox], lon[lox], h[lox] = loxodrome_position(
                self.starts[kl, 0], self.starts[kl, 1], self.starts[kl, 2],
                azimuth=tab.azimuth0[kl], elevation=tab.elevation0[kl],
                t=flat[lox] - tab.s_start[kl], earth=self.earth)
        if not lox.all():                                 # all tracks' Chebyshev chunks
            part = ~lox
            lat[part], lon[part], h[part] = self._chunk_positions(which_a[part], flat[part])
        out.update(lat=lat, lon=lon, h=h, r_e=geodetic_to_ecef(lat, lon, h, earth=self.earth))
        return out


def expanded_points(r_e: Array, C: Array, u_n: Array, du_n: Array, d: Array
                    ) -> tuple[Array, Array]:
    """ECEF position and ENU unit tangent ``δ = d`` (m) past track nodes, to second order:
    ``r + C (u δ + du δ²/2)`` and ``u + du δ``.

    Parameters
    ----------
    r_e : ndarray, shape (K, 3)
        The nodes' ECEF positions, m.
    C : ndarray, shape (K, 3, 3)
        Their ENU-to-ECEF rotations (`trackmodel.earth.C_n_e`).
    u_n, du_n : ndarray, shape (K, 3)
        The tangent (ENU) and its derivative along the track (1/m) there.
    d : ndarray, shape (K,)
        ``s − s_node``, m.
    """
    step_n = u_n * d[:, None] + 0.5 * du_n * (d * d)[:, None]
    return r_e + np.einsum("kij,kj->ki", C, step_n), u_n + du_n * d[:, None]


class NodePoints:
    """ECEF positions and unit tangents on tracks from their nodes (module docstring):
    `ecef`. One object per run (the tables are its own)."""

    def __init__(self) -> None:
        #: ``(id(track), block) -> (track, rows)``, rows ``[r_e, C_n_e, u_n, du_ds_n]``
        #: (18 columns) of the block's nodes.
        self._blocks: dict[tuple[int, int], tuple] = {}

    def _rows(self, track, block: int) -> Array:
        key = (id(track), block)
        entry = self._blocks.get(key)
        if entry is None or entry[0] is not track:
            last = int(math.ceil(track.length_m / NODE_STEP_M))   # the end is a node
            k = np.arange(block * BLOCK_NODES, min((block + 1) * BLOCK_NODES, last + 1))
            p = track.at(np.minimum(k * NODE_STEP_M, track.length_m))
            C = np.asarray(C_n_e(p.lat, p.lon), dtype=float).reshape(-1, 9)
            entry = (track, np.column_stack([np.asarray(p.r_e, dtype=float).reshape(-1, 3),
                                             C, np.asarray(p.u_n).reshape(-1, 3),
                                             np.asarray(p.du_ds_n).reshape(-1, 3)]))
            if len(self._blocks) >= MAX_BLOCKS:
                self._blocks.clear()
            self._blocks[key] = entry
        return entry[1]

    def ecef(self, tracks, s) -> tuple[Array, Array]:
        """ECEF position (m) and unit tangent at ``s[k]`` (m, clamped to the track) on
        ``tracks[k]`` for each k, shapes (K, 3)."""
        if not len(tracks):
            return np.zeros((0, 3)), np.zeros((0, 3))
        # every point's node at once (np.rint: Python's round, half to even; the same
        # IEEE operations as point by point)
        length = np.array([track.length_m for track in tracks], dtype=float)
        s_k = np.minimum(np.maximum(np.array(s, dtype=float), 0.0), length)
        if not np.isfinite(s_k).all():
            raise ValueError(f"track points at s = {s!r}: not finite")
        node = np.minimum(np.rint(s_k / NODE_STEP_M), np.ceil(length / NODE_STEP_M))
        d = s_k - np.minimum(node * NODE_STEP_M, length)
        block, row = np.divmod(node.astype(np.intp), BLOCK_NODES)
        tab = np.array([self._rows(track, b)[r] for track, b, r
                        in zip(tracks, block.tolist(), row.tolist())])
        C = tab[:, 3:12].reshape(-1, 3, 3)
        r, u = expanded_points(tab[:, :3], C, tab[:, 12:15], tab[:, 15:18], d)
        return r, np.einsum("kij,kj->ki", C, u)


def points_on(tracks, s, *, positions: bool = True) -> list[StackPoint]:
    """The point of ``tracks[k]`` at ``s[k]`` (m) for each k, as `trackmodel.track.Track.at`
    gives it (module docstring; tracks on different ellipsoids: one stack per ellipsoid).

    Parameters
    ----------
    tracks : sequence of trackmodel.track.Track
    s : sequence of float
    positions : bool
        Evaluate the positions (``lat``, ``lon``, ``h``, ``r_e``); False: only ``s``,
        ``u_n``, ``azimuth`` and ``elevation`` (the others then raise AttributeError).

    Returns
    -------
    list of StackPoint
    """
    if not len(tracks):
        return []
    # one ellipsoid object (the usual case): no need to hash every track's
    same = all(t.earth is tracks[0].earth for t in tracks)
    earths = {tracks[0].earth} if same else {t.earth for t in tracks}
    if len(earths) > 1:
        out: list = [None] * len(tracks)
        for earth in earths:
            at = [k for k, t in enumerate(tracks) if t.earth == earth]
            for k, p in zip(at, points_on([tracks[k] for k in at], [s[k] for k in at],
                                          positions=positions)):
                out[k] = p
        return out
    distinct: dict[int, int] = {}
    order = []
    for track in tracks:
        if id(track) not in distinct:
            distinct[id(track)] = len(order)
            order.append(track)
    key = tuple(distinct)
    stack = _STACKS.get(key)
    if stack is None or any(a is not b for a, b in zip(stack.tracks, order)):
        stack = TrackStack(order)
        if len(_STACKS) >= MAX_STACKS:
            _STACKS.clear()
        _STACKS[key] = stack
    values = stack.points([distinct[id(t)] for t in tracks], list(s), positions=positions)
    return [StackPoint(values, m) for m in range(len(tracks))]
