"""integrate_on_track (blocks, two passes) against a plain step-by-step loop that
linearizes the track at the current s before every step."""
from __future__ import annotations

import numpy as np

from strapdown.reduced import build_reduced_model, track_parameters
from strapdown.rk4 import rk4_step
from strapdown.track_integration import integrate_on_track
from trackmodel.earth import WGS84
from trackmodel.sections import Section
from trackmodel.track import Track

DT_S = 0.01
# Both linearize within ~1e-7 m of the state; the second-order term |u''|δ²/2 and
# rounding leave differences far below: 1e-9 m in s, 1e-12 rad in attitude.
ATOL_S_M = 1e-9
ATOL_ANGLE_RAD = 1e-12


def test_blocks_match_step_by_step_relinearization():
    track = Track.from_sections([Section(100.0, 10.0, 0.5), Section(60.0, None, None, 0.0, 1 / 300),
                                 Section(200.0, None, None, 1 / 300, elevation_end_deg=1.0),
                                 Section(500.0, None, None)],
                                lat=0.9, lon=0.2, h=50.0, earth=WGS84)
    model = build_reduced_model(WGS84)
    n = 1500
    t = np.arange(n + 1) * DT_S
    u = np.column_stack([0.5 + 0.1 * np.sin(t), 0.05 * np.cos(t), 9.8 + 0.01 * t,
                         1e-3 * np.sin(t), 2e-4 * np.cos(2 * t), -0.02 + 0.01 * np.sin(0.5 * t)])
    x0 = np.array([np.radians(10.0), np.radians(0.5), 0.0, 1.0, 15.0])
    ours = integrate_on_track(model, track, x0, u, DT_S)
    step = rk4_step(model.f)
    x = x0.copy()
    for k in range(n):
        p = track_parameters(track.at(np.clip(x[3], 0, track.length_m)))[0]
        x = np.asarray(step(x, u[k], u[k + 1], p, DT_S)).ravel()
        if k % 250 == 249:
            np.testing.assert_allclose(ours[k + 1, 3], x[3], atol=ATOL_S_M)
            np.testing.assert_allclose(ours[k + 1, :3], x[:3], atol=ATOL_ANGLE_RAD)
