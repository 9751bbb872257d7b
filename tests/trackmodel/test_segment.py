"""The first segmentation (`trackmodel.segment`): pieces of known polynomials recovered."""
from __future__ import annotations

import numpy as np

from trackmodel.pieces import CONST, RAMP
from trackmodel.segment import VERTICAL_KINDS, segment

RMS_M = 0.01                  # segmentation tolerance; the data below are exact


def test_grade_then_vertical_curve_is_found():
    x = np.linspace(0.0, 200.0, 201)
    y = np.where(x < 100.0, 0.01 * x, 1.0 + 0.01 * (x - 100.0) + 1e-4 * (x - 100.0) ** 2)
    shape = segment(x, y, RMS_M, VERTICAL_KINDS)
    assert shape.kinds == (CONST, RAMP)
    assert abs(shape.pieces.knots[1] - 100.0) <= 1.0          # one sample spacing


def test_repeated_positions_are_accepted():
    """Regression: positions repeated (points projected onto one foot) left joints that no
    piece could reach (KeyError 0)."""
    x = np.repeat(np.linspace(0.0, 100.0, 51), 2)
    y = 0.02 * x
    shape = segment(x, y, RMS_M, VERTICAL_KINDS)
    assert shape.kinds == (CONST,)
    assert shape.pieces.length == 100.0
