"""The grid of track parameters (railnav/filters/track_grid.py).

References: `Track.at` at the node itself; and the reduced model evaluated with the track
parameters taken exactly at ``s`` (δ = 0) — the grid's ``s_ref`` is up to half a node
spacing away and the model's second-order expansion must absorb it.
"""
from __future__ import annotations

import numpy as np
import pytest

from railnav.filters.track_grid import GRID_STEP_M, TrackParameterGrid
from railnav.simulation.profiles import constant_speed
from railnav.simulation.scenarios import TRACKS_DIR
from railnav.simulation.truth import ideal_imu, simulate_truth
from strapdown.reduced import build_reduced_model, track_parameters
from trackmodel.io import read_track

#: Neglected third-order term of the tangent: |d³u/ds³| δ³/6 ≲ 1e-7·0.25³/6 ≈ 3e-10, times
#: gravity: 3e-9 m/s² (module docstring); the pseudo-observation must agree to 1e-8 m/s².
ATOL_PSEUDO_OBS_MPS2 = 1e-8


@pytest.fixture(scope="module")
def curvy():
    return read_track(TRACKS_DIR / "curvy.csv")


def test_nearest_node_and_its_parameters(curvy, rng):
    grid = TrackParameterGrid(curvy, window_m=300.0)
    s = np.sort(rng.uniform(0.0, curvy.length_m, 400))
    for chunk in np.split(s, 40):        # windows re-open as the queries move on
        params, idx = grid.parameters(chunk)
        node_s = params[:, 0]
        assert np.all(np.abs(node_s - chunk) <= GRID_STEP_M / 2 + 1e-9)
        np.testing.assert_array_equal(params, track_parameters(curvy.at(node_s),
                                                               earth=curvy.earth))
    params, _ = grid.parameters(np.array([curvy.length_m - 1e-3, curvy.length_m]))
    assert params[-1, 0] == curvy.length_m


def test_grid_reference_reproduces_the_exact_reference(curvy):
    """Along 500 m of curvy.csv with a clothoid, an arc and a vertical curve."""
    truth = simulate_truth(curvy, constant_speed(25.0), duration_s=20.0, rate_hz=100.0,
                           start_s=3900.0)
    imu = ideal_imu(curvy, truth)
    model = build_reduced_model(curvy.earth)
    x = truth.reduced_state()
    exact = track_parameters(curvy.at(truth.s), earth=curvy.earth)
    grid_params, _ = TrackParameterGrid(curvy).parameters(truth.s)
    assert np.max(np.abs(grid_params[:, 0] - truth.s)) > 0.2    # really off the node
    kinds = set(curvy.at(truth.s).section.tolist())
    assert len(kinds) >= 2
    h_exact = np.array([np.asarray(model.h_c(x[k], imu.u[k], exact[k])).ravel()
                        for k in range(0, truth.s.size, 7)])
    h_grid = np.array([np.asarray(model.h_c(x[k], imu.u[k], grid_params[k])).ravel()
                       for k in range(0, truth.s.size, 7)])
    np.testing.assert_allclose(h_grid, h_exact, rtol=0, atol=ATOL_PSEUDO_OBS_MPS2)


def test_a_curvature_step_takes_the_samples_side():
    """A straight of 100.2 m joined to an arc of R 200 m without a transition: nodes at
    100.0 and 100.5 m. A sample at 100.21 m is on the arc but nearer the 100.0-m node (on
    the straight); the grid's node beside the step gives it the arc's curvature. Reference:
    `Track.at` of the sample itself (0 before the step, 1/200 1/m after); the node's
    |du/ds| (level track) is that curvature."""
    from trackmodel.sections import Section
    from trackmodel.track import Track
    track = Track.from_sections([Section(100.2, azimuth_deg=30.0, elevation_deg=0.0),
                                 Section(100.0, curvature_1pm=1 / 200.0)],
                                lat=np.radians(47.0), lon=np.radians(8.0))
    grid = TrackParameterGrid(track)
    s = np.array([99.99, 100.1, 100.19, 100.21, 100.3, 100.45, 150.0])
    params, _ = grid.parameters(s)
    names = ("du_E_ds", "du_N_ds")
    from strapdown.reduced import TRACK_PARAMETER_NAMES
    cols = [TRACK_PARAMETER_NAMES.index(n) for n in names]
    np.testing.assert_allclose(np.hypot(*params[:, cols].T),
                               np.abs(track.at(s).curvature_1pm), atol=1e-9)
    assert np.all(np.abs(params[:, 0] - s) <= GRID_STEP_M / 2 + 1e-9)


def test_parameters_together_are_each_grids_own(curvy, rng):
    """`parameters_together` of four grids (curvy, a parallel, a circle entered straight:
    nodes beside its curvature step; small windows that re-open as the rows move on, at
    different times; samples on nodes and half-way between them) equals each grid's own `parameters` on a twin grid, rows and node
    indices, and leaves each window where the twin's is; rows at a track's start and
    end included."""
    from trackmodel.earth import WGS84
    from trackmodel.offset import offset_track
    from trackmodel.sections import Section
    from trackmodel.track import Origin, Track
    from railnav.filters.track_grid import parameters_together
    circle = Track([Section(300.0, 90.0, 0.0)]
                   + [Section(0.5 * np.pi * 200.0, None, None, 1.0 / 200.0)] * 2,
                   Origin(50.45, 30.52, 100.0), WGS84)
    tracks = [curvy, offset_track(curvy, 4.5), circle, curvy]
    windows = (150.0, 300.0, 60.0, 90.0)

    def grids():
        return [TrackParameterGrid(t, window_m=w) for t, w in zip(tracks, windows)]
    together, alone = grids(), grids()
    start = np.array([0.0, 2000.0, 250.0, curvy.length_m - 240.0])
    speed = np.array([9.0, 14.0, 5.0, 13.0])
    ends = set()
    for step in range(20):
        s = start[:, None] + speed[:, None] * (step + 0.01 * np.arange(101))[None, :] \
            + rng.normal(0.0, 0.2, (4, 101))
        s[:, ::7] = np.round(s[:, ::7] * 4.0) / 4.0       # on nodes and half-way: ties
        s = np.minimum(np.maximum(s, 0.0), np.array([t.length_m for t in tracks])[:, None])
        ends.update({"start"} if s[0].min() == 0.0 else set())
        ends.update({"end"} if s[3].max() == curvy.length_m else set())
        for grid, twin, row, (params, idx) in zip(together, alone, s,
                                                  parameters_together(together, s)):
            ref_params, ref_idx = twin.parameters(row)
            assert np.array_equal(params, ref_params) and np.array_equal(idx, ref_idx)
            assert (grid._lo, grid._hi) == (twin._lo, twin._hi)
    assert ends == {"start", "end"}


def test_point_is_the_windows_node(curvy):
    """`TrackParameterGrid.point` of a node: every field the window's value at that node
    (the fields in their order), a scalar point."""
    from dataclasses import fields
    grid = TrackParameterGrid(curvy, window_m=300.0)
    _, idx = grid.parameters(np.array([4100.0, 4123.4]))
    for i in (0, int(idx[-1]), grid._s.size - 1):
        point = grid.point(i)
        for f in fields(point):
            assert np.array_equal(getattr(point, f.name), getattr(grid._points, f.name)[i])
        assert np.ndim(point.s) == 0 and np.shape(point.r_e) == (3,)
    assert grid.point(int(idx[-1])).s == grid._s[idx[-1]]
