"""The steps at a track's joints (`trackmodel.sections.joint_steps`): the one definition
that the filters' track grid (`railnav.filters.track_grid`) and the simulator's interval
means (`railnav.simulation.joint_average`) use.

References: a hand-made table (closed forms of its jumps), and, on every shipped track
(``data/tracks``) and every netelement of the Brussels network
(``data/networks/brussels_airport``) and of the synthetic switch network, independent
evaluations: `Track.at` either side of each joint (what the grid computed itself before:
its curvature steps) and the file's rows (`Track.sections`: the simulator's exact table
differences before: its rate steps). Both step sets must be those, exactly.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from railnav.filters.track_grid import TrackParameterGrid
from railnav.simulation.switch_network import switch_network
from trackmodel.io import read_track
from trackmodel.network_io import read_network
from trackmodel.origin import Origin
from trackmodel.sections import (
    CURVATURE_STEP_1PM,
    JOINT_SIDE_M,
    Section,
    joint_steps,
)
from trackmodel.track import Track

DATA = Path(__file__).resolve().parents[2] / "data"
TRACK_FILES = sorted(p for p in (DATA / "tracks").rglob("*.csv") if "survey" not in p.name)


def _shipped() -> dict[str, Track]:
    tracks = {p.name: read_track(p) for p in TRACK_FILES}
    for name, network in (("brussels", read_network(DATA / "networks" / "brussels_airport")),
                          ("switch", switch_network())):
        tracks.update({f"{name}:{e}": t for e, t in network.elements.items()})
    return tracks


SHIPPED = _shipped()


def test_a_hand_made_table_has_its_closed_form_jumps():
    """Straight → 500-m arc without transition (κ jumps by 1/500), arc → clothoid to 0
    over 100 m (no jump; across the joint κ changes by the clothoid's rate times
    JOINT_SIDE_M, 2e-11), clothoid → straight with the grade from 0 to 1 % over 200 m
    (a vertical curve: dϑ/ds jumps by 0.01/200 rad/m), then the grade held (jumps back)."""
    kappa = 1.0 / 500.0
    grade = np.degrees(0.01)
    track = Track([Section(100.0, 30.0, 0.0), Section(50.0, None, None, kappa),
                   Section(100.0, None, None, kappa, 0.0),
                   Section(200.0, None, None, 0.0, None, grade),
                   Section(100.0, None, None)], Origin(48.0, 11.0, 500.0))
    steps = joint_steps(track.table)
    np.testing.assert_array_equal(steps.s_m, [100.0, 150.0, 250.0, 450.0])
    np.testing.assert_allclose(steps.curvature_1pm, [kappa, 0.0, 0.0, 0.0], rtol=1e-12)
    np.testing.assert_allclose(steps.grade_rate_1pm, [0.0, 0.0, 0.01 / 200.0,
                                                      -0.01 / 200.0], rtol=1e-9)
    np.testing.assert_allclose(steps.curvature_across_1pm,
                               [kappa, -kappa / 100.0 * JOINT_SIDE_M,
                                -kappa / 100.0 * JOINT_SIDE_M, 0.0],
                               rtol=1e-6, atol=1e-15)
    np.testing.assert_array_equal(steps.curvature_steps_m, [100.0])
    np.testing.assert_array_equal(steps.rate_steps_m, [100.0, 250.0, 450.0])


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_steps_are_those_of_independent_evaluations(name):
    track = SHIPPED[name]
    steps = joint_steps(track.table)
    joints = np.asarray([s for s in np.cumsum([sec.length_m for sec in track.sections])[:-1]])
    np.testing.assert_allclose(steps.s_m, joints, rtol=1e-12, atol=1e-9)
    before, after = track.at(steps.s_m - JOINT_SIDE_M), track.at(steps.s_m + JOINT_SIDE_M)
    across = after.curvature_1pm - before.curvature_1pm
    rows = track.sections
    jump = np.array([b.curvature_1pm - a.curvature_end for a, b in zip(rows, rows[1:])])
    grade_jump = after.elevation_rate - before.elevation_rate
    np.testing.assert_array_equal(steps.curvature_across_1pm, across)
    np.testing.assert_array_equal(steps.curvature_1pm, jump.reshape(steps.s_m.shape))
    np.testing.assert_array_equal(steps.grade_rate_1pm, grade_jump)
    curvature_steps = steps.s_m[np.abs(across) > CURVATURE_STEP_1PM]
    np.testing.assert_array_equal(TrackParameterGrid(track).curvature_steps, curvature_steps)
    np.testing.assert_array_equal(steps.curvature_steps_m, curvature_steps)
    np.testing.assert_array_equal(steps.rate_steps_m,
                                  steps.s_m[(jump != 0.0) | (grade_jump != 0.0)])
