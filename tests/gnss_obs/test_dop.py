"""Dilution of precision: a symmetric geometry with a closed form."""
from __future__ import annotations

import numpy as np

from gnss_obs.dop import dilution_of_precision
from trackmodel.earth import C_n_e


def test_six_axis_geometry_closed_form():
    """Lines of sight ±E, ±N, ±U: GᵀG = diag(2, 2, 2, 6) (the clock column sums to 6, the
    position columns cancel against it), so HDOP = 1, VDOP = 1/√2, TDOP = 1/√6,
    PDOP = √1.5, GDOP = √(1.5 + 1/6)."""
    lat, lon = np.deg2rad(41.6), np.deg2rad(2.35)
    los_n = np.vstack([np.eye(3), -np.eye(3)])
    los_e = los_n @ C_n_e(lat, lon).T
    d = dilution_of_precision(-los_e, np.ones((6, 1)), lat=lat, lon=lon)
    np.testing.assert_allclose([d.hdop, d.vdop, d.tdop, d.pdop, d.gdop],
                               [1.0, np.sqrt(0.5), np.sqrt(1 / 6), np.sqrt(1.5),
                                np.sqrt(1.5 + 1 / 6)], rtol=1e-12)


def test_three_satellites_have_no_dop():
    d = dilution_of_precision(np.eye(3), np.ones((3, 1)), lat=0.0, lon=0.0)
    assert np.isnan(d.gdop)
