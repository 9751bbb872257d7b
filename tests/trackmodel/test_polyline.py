"""Cutting a survey into legs at its reversals (`split_legs`)."""
from __future__ import annotations

import numpy as np

from trackmodel.polyline import (MIN_LEG_M, REVERSAL_CHORD_M, REVERSAL_WINDOW_M, Polyline,
                                 split_legs)
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

LINE = Track([Section(1000.0, 75.0, 0.0)], Origin(41.6, 2.35, 250.0))
SPACING_M = 2.0
#: A leg ends (next one starts) within this of the turning point: the reversal search's
#: chord and window plus a point spacing.
MAX_CUT_M = REVERSAL_CHORD_M + REVERSAL_WINDOW_M + SPACING_M


def _survey(s: np.ndarray) -> Polyline:
    pt = LINE.at(s)
    return Polyline(pt.lat, pt.lon, pt.h)


def test_one_direction_is_one_leg():
    s = np.arange(0.0, 300.0, SPACING_M)
    s = np.concatenate([s[:50], np.full(20, s[50]), s[50:]])     # a stop: repeated points
    legs = split_legs(_survey(s))
    assert len(legs) == 1 and legs[0][0] == 0 and legs[0][-1] == s.size - 1


def test_out_back_and_out_again():
    """Out to 300 m, back to 100 m, out to 250 m: three legs with the right directions, each
    from near its turning point; a 4 m shuffle at the end is a manoeuvre, not a leg."""
    s = np.concatenate([np.arange(0.0, 300.0, SPACING_M), np.arange(300.0, 100.0, -SPACING_M),
                        np.arange(100.0, 250.0, SPACING_M), np.arange(250.0, 246.0, -SPACING_M)])
    legs = split_legs(_survey(s))
    assert len(legs) == 3
    ends = [(s[leg[0]], s[leg[-1]]) for leg in legs]
    for (start, end), (want_start, want_end) in zip(ends, [(0, 300), (300, 100), (100, 250)]):
        assert abs(start - want_start) <= MAX_CUT_M and abs(end - want_end) <= MAX_CUT_M
        assert np.sign(end - start) == np.sign(want_end - want_start)
    assert 4.0 < MIN_LEG_M
