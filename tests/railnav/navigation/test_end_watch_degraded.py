"""A run is stopped at a track end on the filter's σ (`railnav.navigation.loop.TrackEndWatch`);
while the divergence monitor says ``degraded`` that σ is taken times the monitor's
variance factor, as the protection level takes it (`railnav.navigation.protection`).

References: the watch's rule in closed form (beyond by 3σ and moving away by 3σ_v, then on
by 3σ); a plain-files trip (no ``scenario.json``: the real receiver's σ, 14× below the
simulated Doppler's) whose train stands at the track's start for 12 s: its filter's
speed goes wrong at a σ the monitor does not trust, and the run was stopped at 13 s
"beyond the track's start" with the truth at the start; it now runs to the end of the
data.
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from railnav.cli import main
from railnav.jobs.run import run_files
from railnav.navigation.loop import TrackEndWatch, _degraded_variance_factor
from railnav.simulation.scenarios import TRACKS_DIR
from trackmodel.io import read_track


def _filt(length_m: float = 1000.0):
    layout = SimpleNamespace(names=("s", "v"), index=("s", "v").index)
    return SimpleNamespace(layout=layout, track=SimpleNamespace(length_m=length_m))


def _leaves(factor: float) -> bool:
    """Two checks of a vehicle 4σ before the start moving away at 4σ_v, the second 3.5σ
    further on: left on its own σ (the rule's closed form)."""
    watch, filt = TrackEndWatch(), _filt()
    P = np.diag([1.0, 0.01])                                  # σ_s 1 m, σ_v 0.1 m/s
    first = watch.check(filt, np.array([-4.0, -0.4]), P, 0.0, variance_factor=factor)
    second = watch.check(filt, np.array([-7.5, -0.4]), P, 1.0, variance_factor=factor)
    assert first is None                                       # the first is never enough
    return second is not None


def test_a_degraded_filter_is_not_believed_to_leave_on_its_own_sigma():
    assert _leaves(1.0)                  # 7.5σ beyond, 4σ_v away, moved on 3.5σ > 3σ
    assert not _leaves(4.0)              # σ twice as wide: 3.75σ beyond, 2σ_v away
    assert _leaves(1.0 + 1e-12)


def test_the_factor_is_the_monitors_while_degraded_only():
    def monitor(status, f):
        return SimpleNamespace(records=[{"status": status, "variance_factor": f}])
    assert _degraded_variance_factor(None) == 1.0
    assert _degraded_variance_factor(SimpleNamespace(records=[])) == 1.0
    assert _degraded_variance_factor(monitor("degraded", 9.0)) == 9.0
    assert _degraded_variance_factor(monitor("ok", 9.0)) == 1.0        # trusted
    assert _degraded_variance_factor(monitor("degraded", 0.5)) == 1.0  # never narrower
    assert _degraded_variance_factor(monitor("degraded", math.nan)) == 1.0


def test_a_plain_files_trip_standing_at_the_track_start_runs_to_its_end(tmp_path):
    curvy = TRACKS_DIR / "curvy.csv"
    assert main(["-q", "simulate", str(curvy), "--duration-s", "300", "--seed", "0",
                 "--out", str(tmp_path)]) == 0
    (tmp_path / "scenario.json").unlink()                   # plain files: σ unknown
    out = run_files(read_track(curvy), imu_path=tmp_path / "imu.csv",
                    obs_path=tmp_path / "gnss_obs.rnx", nav_path=tmp_path / "gnss_nav.rnx",
                    imu_grade="tactical", truth_path=tmp_path / "truth.csv")
    assert out.result.left_track is None
    assert out.result.estimates["time_s"].iloc[-1] >= 299.0
