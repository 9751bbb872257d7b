"""Synthetic networks of straight sections for the network tests: lengths, positions and
angles known in closed form (sums of section lengths, the diverging azimuth)."""
from __future__ import annotations

import math

import numpy as np

from trackmodel.sections import Section
from trackmodel.track import Track

__all__ = ["straight", "switch_tracks", "DIVERGE_RAD"]

#: The diverging branch's azimuth, rad (a 1:10 switch).
DIVERGE_RAD = 0.1


def straight(lat, lon, length_m: float, azimuth_rad: float) -> Track:
    """A straight of `length_m` from (`lat`, `lon`) (rad, scalars or 1-element arrays)."""
    return Track.from_sections([Section(length_m, math.degrees(azimuth_rad))],
                               lat=float(np.squeeze(lat)), lon=float(np.squeeze(lon)))


def switch_tracks(diverge_rad: float = DIVERGE_RAD) -> dict[str, Track]:
    """T (1000 m north from 50° N 4° E) ending at a switch to S (500 m north) and D (500 m
    at `diverge_rad`); Y runs 300 m south and ends where S ends."""
    t = straight(math.radians(50.0), math.radians(4.0), 1000.0, 0.0)
    s = straight(*t.geodetic(1000.0)[:2], 500.0, 0.0)
    d = straight(*t.geodetic(1000.0)[:2], 500.0, diverge_rad)
    y_start = straight(*s.geodetic(500.0)[:2], 300.0, 0.0).geodetic(300.0)
    return {"T": t, "S": s, "D": d, "Y": straight(*y_start[:2], 300.0, math.pi)}
