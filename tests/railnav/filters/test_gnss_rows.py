"""GNSS rows of the track-based filters (railnav/filters/gnss_rows.py) against a direct computation.

Reference: the observation equations of ARCHITECTURE.md written out here in NumPy,
evaluated at the EXACT track point ``Track.at(s)`` (no linearization), with the receiver
velocity ``v C_n_e u_n``; Jacobians against central differences of that reference.
"""
from __future__ import annotations

import numpy as np
import pytest

from ekf.layout import StateLayout
from gnss_obs.epoch import PreparedEpoch
from railnav.filters.gnss_rows import (
    build_gnss_rows,
    pseudorange_parameters,
    range_rate_parameters,
    track_rows,
)
from trackmodel.earth import C_n_e
from trackmodel.sections import Section
from trackmodel.track import Track

#: The rows expand the track to third order in δ = s − s_ref. The remainder: the frame-
#: rotation part of d³r/ds³ left out (~κ/R δ³/6 ≈ 4e-11 m at δ = 1 m) and fourth-order
#: terms (κ³δ⁴/24 ≈ 2e-10 m on a 600 m curve); the ranges themselves are 2e7 m, whose
#: double-precision rounding is 4e-9 m.
ATOL_RANGE_M = 1e-8
#: Range rate at 20 m/s: the tangent of integrated (Chebyshev-stored) sections is exact to
#: ~1e-8 (trackmodel's own tests), i.e. 2e-7 m/s; a second-order expansion would err by
#: v |dκ/ds| δ²/2 ≈ 1.4e-4 m/s on this transition and fail.
ATOL_RATE_MPS = 1e-6
#: Fourth-order central differences with h = 0.5: rounding of 2e7-m ranges ~4e-9·1.5/h ≈
#: 1.2e-8, truncation h⁴|d⁵ρ/ds⁵|/30 below 1e-10 (a second-order difference with h = 1 m
#: would err by |e·dk/ds|/6 ≈ 2e-6 on the transition).
RTOL_JACOBIAN = 1e-7
FD_STEP = 0.5
#: Rounding floor of that stencil on 2e7-m ranges: ulp 3.7e-9 m × 18/(12 h) ≈ 1.1e-8.
ATOL_RANGE_JACOBIAN = 2e-8
#: ∂(range rate)/∂s of the third-order expansion differs from the exact track's by the
#: next term, v·|d³t/ds³|·δ²/2 with |d³t/ds³| ≈ 3κκ' on a transition: 20·3·(1/1200)·
#: (1/72000)/2 ≈ 3.5e-7 (m/s)/m at δ = 1 m.
ATOL_RATE_JACOBIAN_S = 1e-6
DELTA_M = 1.0

LAYOUT = StateLayout.from_blocks([("attitude", ("yaw", "pitch", "roll")), ("s", 1), ("v", 1),
                                  ("clock", ("clock_bias", "clock_drift")),
                                  ("isb", ("isb_E",))])


@pytest.fixture(scope="module")
def track():
    """A clothoid into a 600 m curve on a 1 % grade with a vertical curve (WGS-84)."""
    sections = [Section(200.0, azimuth_deg=75.0, elevation_deg=0.57),
                Section(120.0, curvature_1pm=0.0, curvature_end_1pm=1 / 600,
                        elevation_end_deg=0.2),
                Section(400.0, curvature_1pm=1 / 600)]
    return Track.from_sections(sections, lat=np.radians(48.1), lon=np.radians(11.5), h=520.0)


def _satellites(track, s, rng, n=6):
    """Satellites ~20 000 km away in random directions above the receiver."""
    p = track.at(s)
    up = C_n_e(p.lat, p.lon)[:, 2]
    dirs = rng.normal(size=(n, 3))
    dirs = dirs / np.linalg.norm(dirs, axis=1)[:, None]
    dirs = np.where((dirs @ up)[:, None] > 0.2, dirs, -dirs)
    sat_pos = p.r_e + 2.02e7 * dirs
    sat_vel = rng.normal(scale=2000.0, size=(n, 3))
    system = np.array(["G"] * (n - 2) + ["E"] * 2, dtype=object)
    z = np.zeros(n)
    return PreparedEpoch(
        gps_time_s=0.0, sv=np.array([f"X{i:02d}" for i in range(n)], dtype=object),
        system=system, sat_pos_e=sat_pos, sat_vel_e=sat_vel,
        sat_clock_m=rng.normal(scale=1e4, size=n), sat_clock_drift_mps=rng.normal(size=n),
        iono_m=rng.uniform(1, 10, n), tropo_m=rng.uniform(2, 20, n), elevation=z, azimuth=z,
        pseudorange_m=z, range_rate_mps=z, cn0_dbhz=z, sigma_pr_m=z + 1, sigma_rr_mps=z + 1)


def _reference(track, prep, x):
    """Pseudorange and range rate at the exact track point, written out (NumPy)."""
    s, v = x[LAYOUT.index("s")], x[LAYOUT.index("v")]
    p = track.at(s)
    r = p.r_e
    v_e = v * (C_n_e(p.lat, p.lon) @ p.u_n)
    los = prep.sat_pos_e - r
    rng_ = np.linalg.norm(los, axis=1)
    bias = x[LAYOUT.index("clock_bias")] + np.where(prep.system == "E",
                                                    x[LAYOUT.index("isb_E")], 0.0)
    rho = rng_ + bias - prep.sat_clock_m + prep.iono_m + prep.tropo_m
    rate = np.einsum("ki,ki->k", los / rng_[:, None], prep.sat_vel_e - v_e) \
        + x[LAYOUT.index("clock_drift")] - prep.sat_clock_drift_mps
    return rho, rate


@pytest.mark.parametrize("s_ref", [150.0, 260.0, 500.0])   # straight, clothoid, arc
def test_rows_equal_the_direct_model_and_its_derivatives(track, rng, s_ref):
    rows = build_gnss_rows(LAYOUT, ("isb_E",))
    prep = _satellites(track, s_ref, rng)
    part = track_rows(track.at(s_ref), earth=track.earth)
    p_pr = pseudorange_parameters(part, prep, ("E",))
    p_rr = range_rate_parameters(part, prep)
    x = np.zeros(LAYOUT.size)
    x[LAYOUT.index("s")] = s_ref + DELTA_M
    x[LAYOUT.index("v")] = 20.0
    x[LAYOUT.index("clock_bias")], x[LAYOUT.index("clock_drift")] = 1234.5, -0.7
    x[LAYOUT.index("isb_E")] = 8.25
    rho, H_pr = rows.pseudorange.evaluate(x, p_pr)
    rate, H_rr = rows.range_rate.evaluate(x, p_rr)
    rho_ref, rate_ref = _reference(track, prep, x)
    np.testing.assert_allclose(rho, rho_ref, rtol=0, atol=ATOL_RANGE_M)
    np.testing.assert_allclose(rate, rate_ref, rtol=0, atol=ATOL_RATE_MPS)
    for name in ("s", "v", "clock_bias", "clock_drift", "isb_E"):
        i = LAYOUT.index(name)
        dx = np.zeros(LAYOUT.size)
        dx[i] = FD_STEP
        f = [np.array(_reference(track, prep, x + k * dx)) for k in (2, 1, -1, -2)]
        fd = (-f[0] + 8 * f[1] - 8 * f[2] + f[3]) / (12 * FD_STEP)
        np.testing.assert_allclose(H_pr[:, i], fd[0], rtol=RTOL_JACOBIAN,
                                   atol=ATOL_RANGE_JACOBIAN)
        np.testing.assert_allclose(H_rr[:, i], fd[1],
                                   rtol=RTOL_JACOBIAN,
                                   atol=ATOL_RATE_JACOBIAN_S if name == "s" else 1e-9)
    # attitude does not enter GNSS (no lever arm)
    att = LAYOUT.slice("attitude")
    assert not H_pr[:, att].any() and not H_rr[:, att].any()


def test_cross3_is_numpys_cross_bit_for_bit(rng):
    """Reference: `np.cross` (the rows' curvature term used it before)."""
    from railnav.filters.gnss_rows import _cross3
    for _ in range(200):
        a, b = rng.standard_normal(3) * 10 ** rng.uniform(-8, 3), rng.standard_normal(3)
        assert _cross3(a, b).tobytes() == np.cross(a, b).tobytes()
