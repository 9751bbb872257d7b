"""A hypothesis's state brought onto another track: the network navigator's conversions.

`converted` gives the state and covariance of a filter on one track as a filter on another
track abreast would carry them (`railnav.navigation.bank.moved_state`): ``s`` of the target
track's point nearest the source's (one Newton step from the offset last found for the pair
of tracks, else the projection), the attitude turned by the tracks' angles, and for filters
whose speed is signed also between tracks that run opposite ways (``v`` negated).
`converted_pairs` converts many pairs with their track points evaluated together (the same
numbers). The IMM restarts (`railnav.navigation.network_weights.mix_states`) and the
candidate starts of a network run (`railnav.jobs.network`) use them.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from railnav.errors import RailnavError
from railnav.navigation.bank import moved_states
from trackmodel.earth import C_n_e
from trackmodel.network_points import point_fields, points_on

__all__ = ["converted", "converted_pairs", "forget_offsets", "known_offset", "known_offsets",
           "signed_speed",
           "NEWTON_MAX_STEP_M", "MAX_OFFSETS"]

Array = npt.NDArray[np.float64]


def signed_speed(filt) -> bool:
    """Whether a filter's travel direction is its speed's sign (no attitude states)."""
    return "yaw" not in filt.layout.names


#: Offsets ``s_target − s_source`` found for pairs of tracks, for the next conversion
#: (by the tracks' ``id``: forgotten at the start of each run, `forget_offsets`, so that a
#: run's numbers do not depend on the runs before it in the process, whose freed tracks'
#: ids new tracks may reuse).
_OFFSETS: dict[tuple[int, int], float] = {}
#: A Newton step longer than this (m) means the guess was poor: project instead.
NEWTON_MAX_STEP_M = 1.0
#: Pairs remembered at most (then forgotten together).
MAX_OFFSETS = 10_000


def forget_offsets() -> None:
    """Forget the offsets found so far (a run's start: `_OFFSETS`)."""
    _OFFSETS.clear()


def known_offset(source_track, target_track) -> float | None:
    """The offset ``s_target − s_source`` last found for this pair of tracks, or None."""
    return _OFFSETS.get((id(source_track), id(target_track)))


def known_offsets(tracks) -> list[tuple[int, int, float]]:
    """``(i, j, known_offset(tracks[i], tracks[j]))`` of every ordered pair ``i != j``
    that has one, in the order of ``i`` then ``j`` (each track's ``id`` taken once)."""
    ids = [id(t) for t in tracks]
    get = _OFFSETS.get
    return [(i, j, offset) for i, a in enumerate(ids) for j, b in enumerate(ids)
            if i != j and (offset := get((a, b))) is not None]


def _target_s(sources, targets, p_src: list, s_src: list, first_points=None) -> list[float]:
    """``s`` of the point of each target's track nearest its source's point ``p_src`` at
    ``s_src``: one Newton step along the target's tangent from the offset last found for
    the pair of tracks (once the offset of the pair is known), else the projection.

    Pairs are taken in order; a pair of tracks met again within the batch starts from the
    offset its previous occurrence found (waves: the k-th occurrences together).
    `first_points`: a callable giving the first wave's Newton points on the targets (made
    with the sources' points in one evaluation, `converted_pairs`)."""
    keys = [(id(a.track), id(b.track)) for a, b in zip(sources, targets)]
    seen: dict[tuple[int, int], int] = {}
    waves: list[list[int]] = []
    for k, key in enumerate(keys):
        n = seen.get(key, 0)
        seen[key] = n + 1
        if n == len(waves):
            waves.append([])
        waves[n].append(k)
    out = [0.0] * len(keys)
    for wave in waves:
        if len(_OFFSETS) + len(wave) > MAX_OFFSETS:      # where the table is cleared: as
            for k in wave:                               # pair by pair
                out[k] = _one_target_s(sources[k], targets[k], p_src[k], s_src[k], keys[k])
            continue
        guessed = [k for k in wave if keys[k] in _OFFSETS]
        s_g = [min(max(s_src[k] + _OFFSETS[keys[k]], 0.0), targets[k].track.length_m)
               for k in guessed]
        points = first_points(guessed, s_g) if first_points is not None and wave is waves[0] \
            else points_on([targets[k].track for k in guessed], s_g)
        newton = dict(zip(guessed, _newton_many(points, [p_src[k] for k in guessed], s_g)))
        for k in wave:
            found = newton.get(k)
            if found is None:
                found = _projected(targets[k], p_src[k])
            _OFFSETS[keys[k]] = found - s_src[k]
            out[k] = found
    return out


def _newton_many(p_g: list, p_src: list, s_g: list) -> list[float | None]:
    """For each ``k``: ``s`` one Newton step from ``s_g[k]`` (its point ``p_g[k]``) along
    the target's tangent towards the point nearest ``p_src[k]``; None when the step is
    longer than `NEWTON_MAX_STEP_M`. The rotations and products of all at once
    (`trackmodel.earth.C_n_e` elementwise; NumPy's stacked ``matmul`` makes each point's
    BLAS products as a point's own would: the same numbers)."""
    if not p_g:
        return []
    lat, lon, u_n, r_g = point_fields(p_g, "lat", "lon", "u_n", "r_e")
    lat, lon = lat.reshape(-1), lon.reshape(-1)
    d = r_g - point_fields(p_src, "r_e")[0]
    tangent = (np.asarray(C_n_e(lat, lon)).reshape(-1, 3, 3) @ u_n[..., None])
    step = -(d[:, None, :] @ tangent)[:, 0, 0]
    return [g + float(st) if abs(float(st)) <= NEWTON_MAX_STEP_M else None
            for g, st in zip(s_g, step)]


def _projected(target, p_src) -> float:
    """``s`` of the projection of `p_src` onto `target`'s track."""
    return float(target.track.project(p_src.lat, p_src.lon, p_src.h).s[0])


def _one_target_s(source, target, p_src, s_src: float, key) -> float:
    """`_target_s` of one pair, the offsets table cleared when it is full."""
    guess = _OFFSETS.get(key)
    if guess is not None:
        s_g = min(max(s_src + guess, 0.0), target.track.length_m)
        found = _newton_many([target.track.at(s_g)], [p_src], [s_g])[0]
        if found is not None:
            _OFFSETS[key] = found - s_src
            return found
    s_tgt = _projected(target, p_src)
    if len(_OFFSETS) > MAX_OFFSETS:
        _OFFSETS.clear()
    _OFFSETS[key] = s_tgt - s_src
    return s_tgt


def converted(source, target, x: Array, P: Array) -> tuple[Array, Array]:
    """`railnav.navigation.bank.convert_state` (``s`` by `_target_s`), and for filters
    whose speed is signed also between tracks that run opposite ways there: ``s`` from the
    projection, ``v`` (and its covariances) negated."""
    return converted_pairs([source], [target], [x], [P])[0]


def converted_pairs(sources, targets, xs, Ps, *, source_points: list | None = None,
                    first_guesses: list | None = None) -> list[tuple[Array, Array]]:
    """`converted` of each pair ``(sources[k], targets[k], xs[k], Ps[k])``, in order, the
    track points of all pairs evaluated together (`trackmodel.network_points.points_on`:
    the same numbers as `trackmodel.track.Track.at` point by point); `source_points`: the
    sources' points at their clamped ``s`` when known; `first_guesses`: for each pair,
    ``(s_g, point)`` of its target's track, or None (`cycle_points`), used as the first
    wave's Newton point where ``s_g`` is the one that wave asks for."""
    if not sources:
        return []
    s_raw = [float(x[f.layout.index("s")]) for x, f in zip(xs, sources)]
    s_src = [min(max(s, 0.0), f.track.length_m) for s, f in zip(s_raw, sources)]
    # the sources' points and the first Newton points need nothing from each other: together
    first = _first_wave(sources, targets, s_src)
    if source_points is None:
        both = points_on([f.track for f in sources] + [targets[k].track for k in first],
                         s_src + list(first.values()))
        p_src, newton_points = both[:len(sources)], both[len(sources):]
    else:
        p_src = list(source_points)
        known = {k: first_guesses[k][1] for k in first if first_guesses is not None
                 and first_guesses[k] is not None and first_guesses[k][0] == first[k]}
        order = list(first)
        newton_points = [known.get(k) for k in order]
        missing = [m for m, k in enumerate(order) if k not in known]
        for m, p in zip(missing, points_on([targets[order[m]].track for m in missing],
                                           [first[order[m]] for m in missing])):
            newton_points[m] = p
    newton = dict(zip(first, newton_points))

    def first_points(guessed, s_g):
        if all(k in newton for k in guessed):
            return [newton[k] for k in guessed]
        return points_on([targets[k].track for k in guessed], s_g)

    s_tgt = _target_s(sources, targets, p_src, s_src, first_points)
    # the targets' tangents and angles only (`_converted_all` reads no position of them)
    p_tgt = points_on([f.track for f in targets],
                      [min(max(s, 0.0), f.track.length_m) for s, f in zip(s_tgt, targets)],
                      positions=False)
    return _converted_all(sources, xs, Ps, s_raw, s_src, s_tgt, p_src, p_tgt)


def _first_wave(sources, targets, s_src: list) -> dict[int, float]:
    """``s_g`` of the pairs of `_target_s`'s first wave that have an offset to start from,
    by pair index (what `_target_s` computes for them; the table is read, not changed)."""
    out, seen = {}, set()
    if len(_OFFSETS) + len(sources) > MAX_OFFSETS:
        return out
    for k, (a, b) in enumerate(zip(sources, targets)):
        key = (id(a.track), id(b.track))
        if key in seen:
            continue
        seen.add(key)
        if key in _OFFSETS:
            out[k] = min(max(s_src[k] + _OFFSETS[key], 0.0), b.track.length_m)
    return out


def _converted_all(sources, xs, Ps, s_raw: list, s_src: list, s_tgt: list, p_src: list,
                   p_tgt: list) -> list[tuple[Array, Array]]:
    """`converted` of every pair once the track points are known: the pairs whose tracks
    run the same way there moved together per layout (`moved_states`: the same numbers
    as `moved_state` pair by pair), the others (``v`` negated) one by one."""
    (u_src, az_src, el_src), (u_tgt, az_tgt, el_tgt) = (
        point_fields(points, "u_n", "azimuth", "elevation") for points in (p_src, p_tgt))
    out: list = [None] * len(sources)
    same: dict[tuple, list[int]] = {}
    for k, (source, a, b) in enumerate(zip(sources, u_src, u_tgt)):
        if float(np.dot(a, b)) > 0.0:
            same.setdefault(source.layout.names, []).append(k)
        else:
            out[k] = _reversed(source, xs[k], Ps[k], s_raw[k], s_src[k], s_tgt[k])
    for ks in same.values():
        s_new = np.array([s_tgt[k] + (s_raw[k] - s_src[k]) for k in ks])
        moved = moved_states(sources[ks[0]].layout, np.array([xs[k] for k in ks],
                                                             dtype=float),
                             s_new, *(a.reshape(-1)[ks] for a in (az_src, az_tgt, el_src,
                                                                   el_tgt)))
        for k, x in zip(ks, moved):
            out[k] = (x, Ps[k])
    return out


def _reversed(source, x: Array, P: Array, s_raw: float, s_src: float, s_tgt: float
              ) -> tuple[Array, Array]:
    """`converted` of a pair whose tracks run opposite ways: ``v`` (and its covariances)
    negated, for filters whose speed is signed."""
    lay = source.layout
    if not signed_speed(source):
        raise RailnavError(f"the tracks run opposite ways at s = {s_src:.1f} m: an "
                           "inertial filter's state cannot be brought across")
    flip = np.ones(x.size)
    flip[lay.index("v")] = -1.0
    out = x * flip
    out[lay.index("s")] = s_tgt + (s_raw - s_src) * -1.0
    return out, P * np.outer(flip, flip)
