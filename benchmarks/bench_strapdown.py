"""Speed of the truth/IMU simulator and of the mechanizations over 100 000 IMU samples.

1000 s at 100 Hz on a paper-like track (sphere, A = 30°, ϑ = 3°, 25 km straight) and on
a WGS-84 track with a clothoid-arc-clothoid curve and a vertical curve, error-free IMU.
Timed in one process (first call includes CasADi's one-off block construction):

* ``simulate``           — `railnav.simulation.truth.simulate_truth` + `ideal_imu`;
* ``full_rk4``           — 9-state model, `strapdown.rk4.integrate`;
* ``reduced_rk4``        — reduced model, track parameters given per step;
* ``reduced_on_track``   — reduced model following its own s (`integrate_on_track`).

Writes ``benchmarks/results/strapdown.json``. Run: ``python benchmarks/bench_strapdown.py``.
"""
from __future__ import annotations

import json
import platform
import time
from pathlib import Path

import numpy as np

from railnav.simulation.profiles import constant_speed
from railnav.simulation.truth import ideal_imu, simulate_truth
from strapdown.mechanization import build_full_model
from strapdown.reduced import build_reduced_model, track_parameters
from strapdown.rk4 import integrate
from strapdown.track_integration import integrate_on_track
from trackmodel.earth import WGS84, sphere
from trackmodel.sections import Section
from trackmodel.track import Track

RESULTS = Path(__file__).resolve().parent / "results" / "strapdown.json"
DURATION_S = 1000.0
SPEED_MPS = 20.0


def _tracks() -> dict[str, Track]:
    paper = Track.from_sections([Section(25_000.0, 30.0, 3.0)], lat=np.radians(50.45),
                                lon=np.radians(30.52), h=100.0, earth=sphere())
    curvy = Track.from_sections(
        [Section(1500.0, 75.0, 0.2), Section(150.0, None, None, 0.0, 1 / 800),
         Section(500.0, None, None, 1 / 800), Section(150.0, None, None, 1 / 800, 0.0),
         Section(400.0, None, None, elevation_end_deg=0.6), Section(20_000.0, None, None)],
        lat=np.radians(48.0), lon=np.radians(11.0), h=500.0, earth=WGS84)
    return {"paper": paper, "curvy": curvy}


def _timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def main() -> None:
    results = {"steps": int(DURATION_S * 100), "machine": platform.machine(),
               "python": platform.python_version(), "tracks": {}}
    for name, track in _tracks().items():
        (truth, imu), t_sim = _timed(lambda: (lambda tr: (tr, ideal_imu(track, tr)))(
            simulate_truth(track, constant_speed(SPEED_MPS), duration_s=DURATION_S)))
        full, reduced = build_full_model(track.earth), build_reduced_model(track.earth)
        x0 = np.r_[truth.yaw[0], truth.pitch[0], truth.roll[0], truth.v_n[0], truth.lat[0],
                   truth.lon[0], truth.h[0]]
        _, t_full = _timed(lambda: integrate(full.f, x0, imu.u, imu.dt))
        xr0 = np.r_[truth.yaw[0], truth.pitch[0], truth.roll[0], truth.s[0], truth.v[0]]
        p = track_parameters(track.at(truth.s[:-1]), earth=track.earth)
        _, t_red = _timed(lambda: integrate(reduced.f, xr0, imu.u, imu.dt, p))
        _, t_red2 = _timed(lambda: integrate(reduced.f, xr0, imu.u, imu.dt, p))
        _, t_track = _timed(lambda: integrate_on_track(reduced, track, xr0, imu.u, imu.dt))
        results["tracks"][name] = {"simulate_s": t_sim, "full_rk4_s": t_full,
                                   "reduced_rk4_first_s": t_red, "reduced_rk4_s": t_red2,
                                   "reduced_on_track_s": t_track}
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(results, indent=2) + "\n")
    print(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
