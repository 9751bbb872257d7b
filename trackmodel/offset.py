r"""A parallel track: the other track of a double line, at a constant horizontal offset.

`offset_track` builds, section by section, the track whose points lie at the horizontal
distance ``d`` to the right (``d < 0``: left) of a given track, at the same height at
each cross-section (no cant). With the horizontal curvature ``k = κ / cos ϑ`` (``κ = dA/ds``
per metre of 3-D length, `trackmodel.sections`) and ``x`` the horizontal distance along
the given track, the parallel track has

    k_B = k / (1 − k d),     dx_B = (1 − k d) dx,     tan ϑ_B = tan ϑ / (1 − k d),

(a right turn, ``k > 0``, with ``d > 0`` is the inner track of radius ``R − d``; on a grade
the inner track is steeper because it climbs the same height over a shorter distance).
Straights are copied as they are (exact). A circular arc at a constant grade stays one
(exact). Sections whose curvature or elevation varies (clothoids, vertical curves in a
curve) are cut into pieces of at most `PIECE_M`; each piece gets the parallel track's
elevation at its two ends (linear in between), the length ``∫(1 − k d) dx / cos ϑ_B``
(exact for a linear ``k`` on the flat), its start curvature continuing the previous piece's
and the end curvature that makes its turn ``∫κ_B ds_B`` equal the given piece's, so the
azimuth stays parallel after every piece (the end curvatures stay within ~1e-4 of
``k_B``; exact curvatures at both ends would leave 2.6e-6 rad of azimuth after a 120-m
transition into a 600-m radius at 4.5 m). The geographic azimuth is kept: the parallel of
a loxodrome at a constant azimuth drifts laterally by ``d tan φ Δφ`` (~2 cm over 20 km
northward at 48°), which the tests bound.
"""
from __future__ import annotations

import math

import numpy as np

from trackmodel.earth import ecef_to_geodetic, enu_to_ecef
from trackmodel.errors import TrackError
from trackmodel.origin import Origin
from trackmodel.sections import Section
from trackmodel.track import Track

__all__ = ["offset_track", "PIECE_M", "MAX_CURVATURE_OFFSET"]

#: End curvatures this close (relative) are one constant curvature (rounding of an arc).
SAME_CURVATURE_REL = 1e-12

#: Longest piece of a section whose curvature or elevation varies, m.
PIECE_M = 10.0
#: The offset must keep ``|k d|`` below this (the parallel of a curve must not be closer
#: to the curve's centre than half its radius).
MAX_CURVATURE_OFFSET = 0.5


def offset_track(track: Track, offset_m: float) -> Track:
    """The track parallel to `track` at a horizontal distance `offset_m` to its right.

    Parameters
    ----------
    track : Track
    offset_m : float
        Horizontal distance between the two tracks' centre lines, m; positive: the new
        track is to the right of the direction of increasing ``s``.

    Returns
    -------
    Track
        Same Earth model; its ``s = 0`` is abreast of the given track's.

    Raises
    ------
    TrackError
        For a non-finite offset, or a curve too tight for it (`MAX_CURVATURE_OFFSET`).
    """
    d = float(offset_m)
    if not math.isfinite(d):
        raise TrackError(f"offset_m must be finite, got {offset_m!r}")
    table = track.table
    sections: list[Section] = []
    for k in range(len(track.sections)):
        sections.extend(_offset_section(table, k, d))
    first = sections[0]
    sections[0] = Section(first.length_m, math.degrees(table.azimuth0[0]),
                          math.degrees(_parallel(table.curvature0[0], table.elevation0[0], d)[1]),
                          first.curvature_1pm, first.curvature_end_1pm,
                          first.elevation_end_deg)
    return Track(sections, _origin(track, d), track.earth)


def _parallel(kappa: float, elevation: float, d: float) -> tuple[float, float]:
    """Curvature ``κ_B`` (1/m of 3-D length) and elevation ``ϑ_B`` (rad) of the parallel
    track abreast of a point with curvature `kappa` and elevation `elevation`."""
    k_h = kappa / math.cos(elevation)
    shrink = 1.0 - k_h * d
    if not abs(k_h * d) < MAX_CURVATURE_OFFSET:
        raise TrackError(f"an offset of {d:g} m is too large for a curve of radius "
                         f"{1.0 / abs(k_h):.1f} m (|offset / radius| must be < "
                         f"{MAX_CURVATURE_OFFSET})")
    elevation_b = math.atan(math.tan(elevation) / shrink)
    return k_h / shrink * math.cos(elevation_b), elevation_b


def _offset_section(table, k: int, d: float) -> list[Section]:
    """The parallel track's sections abreast of section `k` of the table."""
    L = float(table.length[k])
    k0, k1 = float(table.curvature0[k]), float(table.curvature1[k])
    e0, e1 = float(table.elevation0[k]), float(table.elevation1[k])
    if k0 == 0.0 and k1 == 0.0:
        return [Section(L, None, None, 0.0, None,
                        None if e1 == e0 else math.degrees(e1))]
    n = 1 if (k0 == k1 and e0 == e1) else max(1, math.ceil(L / PIECE_M))
    t = np.linspace(0.0, L, n + 1)
    kappa = k0 + (k1 - k0) * t / L
    elevation = e0 + (e1 - e0) * t / L
    out = []
    kb_a = _parallel(kappa[0], elevation[0], d)[0]
    for a, b in zip(range(n), range(1, n + 1)):
        eb_a = _parallel(kappa[a], elevation[a], d)[1]
        eb_b = _parallel(kappa[b], elevation[b], d)[1]
        e_mid = 0.5 * (elevation[a] + elevation[b])
        k_h = 0.5 * (kappa[a] + kappa[b]) / math.cos(e_mid)
        length = (t[b] - t[a]) * math.cos(e_mid) * (1.0 - k_h * d) / math.cos(0.5 * (eb_a + eb_b))
        turn = (t[b] - t[a]) * 0.5 * (kappa[a] + kappa[b])
        kb_b = 2.0 * turn / length - kb_a     # the piece turns exactly as much as the given
        same = abs(kb_b - kb_a) <= SAME_CURVATURE_REL * abs(kb_a)
        out.append(Section(length, None, None, kb_a, None if same else kb_b,
                           None if eb_b == eb_a else math.degrees(eb_b)))
        kb_a = kb_a if same else kb_b
    return out


def _origin(track: Track, d: float) -> Origin:
    """The point `d` to the right of the track's origin, horizontally."""
    azimuth = float(track.table.azimuth0[0])
    right_n = d * np.array([math.cos(azimuth), -math.sin(azimuth), 0.0])
    o = track.origin
    r_e = enu_to_ecef(right_n, lat0=o.lat, lon0=o.lon, h0=o.h_m, earth=track.earth)
    lat, lon, h = ecef_to_geodetic(r_e, earth=track.earth)
    return Origin(math.degrees(float(lat)), math.degrees(float(lon)), float(h))
