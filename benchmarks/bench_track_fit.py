"""Speed and parsimony of the track fitter (`trackmodel.fit.fit_track`), in one process.

Surveys:

* ``barcelona`` — the real drive ``data/tracks/barcelona_drive_survey.csv`` (395 PPK
  points, stops, 90° street corners of 10–20 m radius), with heights;
* ``curvy`` — a synthetic survey of ``data/tracks/curvy.csv`` (~30 km, 32 sections):
  1000 points at uniformly random positions, 0.1 m horizontal and vertical noise, heights.

For each: wall time, section count (and the true count for the synthetic one), the
largest and RMS horizontal deviation of the survey points from the **built** track
(every point projected on the `Track`), the start/end overhang (how far the track runs
before the first point's foot and after the last one's, m) and the smallest radius.

``--old REV`` also runs the fitter of an earlier commit (its ``trackmodel`` extracted
with ``git archive`` into a temporary folder and run in a subprocess), for the same
figures measured in the same invocation.

Writes ``benchmarks/results/track_fit.json``. Run: ``python benchmarks/bench_track_fit.py``.
"""
from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from trackmodel.earth import C_n_e, ecef_to_geodetic
from trackmodel.files import atomic_write_text
from trackmodel.fit import fit_track
from trackmodel.io import read_track

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results" / "track_fit.json"
SURVEY = ROOT / "data" / "tracks" / "barcelona_drive_survey.csv"
CURVY = ROOT / "data" / "tracks" / "curvy.csv"
N_SYNTHETIC = 1000
NOISE_M = 0.1
SEED = 20240611
TOL_M = 0.5
VTOL_M = 1.0


def surveys() -> dict[str, tuple]:
    """``name -> (lat rad, lon rad, h m, true section count or None)``."""
    sv = pd.read_csv(SURVEY)
    out = {"barcelona": (np.radians(sv.lat_deg.to_numpy()), np.radians(sv.lon_deg.to_numpy()),
                         sv.h_m.to_numpy(), None)}
    truth = read_track(CURVY)
    rng = np.random.default_rng(SEED)
    s = np.sort(rng.uniform(0.0, truth.length_m, N_SYNTHETIC))
    s[0], s[-1] = 0.0, truth.length_m
    pt = truth.at(s)
    d_n = rng.normal(0.0, NOISE_M, (len(s), 3))
    lat, lon, h = ecef_to_geodetic(pt.r_e + np.einsum("...ij,...j->...i",
                                                      C_n_e(pt.lat, pt.lon), d_n))
    out["curvy"] = (lat, lon, h, len(truth.sections))
    return out


def measure(fit, lat, lon, h) -> dict:
    """Fit, then check the built track against every survey point."""
    t0 = time.perf_counter()
    track = fit(lat, lon, h)
    wall = time.perf_counter() - t0
    proj = track.project(lat, lon, h)
    dev = np.hypot(proj.cross_track_m, proj.along_m)
    curvature = np.abs(np.concatenate([track.table.curvature0, track.table.curvature1]))
    return {"wall_s": wall, "sections": len(track.sections), "length_m": track.length_m,
            "max_horizontal_m": float(dev.max()),
            "rms_horizontal_m": float(np.sqrt(np.mean(dev ** 2))),
            "max_vertical_m": float(np.abs(proj.vertical_m).max()),
            "overhang_start_m": float(proj.s.min()),
            "overhang_end_m": float(track.length_m - proj.s.max()),
            "min_radius_m": float(1.0 / curvature.max()) if curvature.max() > 0 else None}


def new_fit(lat, lon, h):
    return fit_track(lat, lon, h, tol_m=TOL_M, vtol_m=VTOL_M).track


OLD_RUNNER = """
import pickle, sys
from trackmodel.fit import fit_track
from trackmodel.io import write_track
lat, lon, h = pickle.load(open(sys.argv[1], "rb"))
write_track(fit_track(lat, lon, h, tol_m={tol}, vtol_m={vtol}).track, sys.argv[2])
"""


def old_fit_factory(rev: str, workdir: Path):
    """A fit function running the `trackmodel` of commit `rev` in a subprocess."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "trackmodel"],
                             check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(workdir)], input=archive, check=True)
    runner = workdir / "run_old.py"
    runner.write_text(OLD_RUNNER.format(tol=TOL_M, vtol=VTOL_M))

    def fit(lat, lon, h):
        import pickle
        data, out = workdir / "survey.pkl", workdir / "track.csv"
        data.write_bytes(pickle.dumps((lat, lon, h)))
        subprocess.run([sys.executable, str(runner), str(data), str(out)], check=True,
                       cwd=workdir, env={"PYTHONPATH": str(workdir), "PATH": "/usr/bin:/bin"})
        return read_track(out)
    return fit


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", metavar="REV", default=None,
                        help="also run the fitter of this commit (e.g. HEAD~1)")
    args = parser.parse_args()
    results: dict = {"python": platform.python_version(), "machine": platform.machine(),
                     "tol_m": TOL_M, "vtol_m": VTOL_M, "surveys": {}}
    with tempfile.TemporaryDirectory() as tmp:
        old = old_fit_factory(args.old, Path(tmp)) if args.old else None
        for name, (lat, lon, h, true_sections) in surveys().items():
            entry = {"points": len(lat), "true_sections": true_sections,
                     "new": measure(new_fit, lat, lon, h)}
            if old is not None:
                entry["old"] = measure(old, lat, lon, h)
                entry["old"]["rev"] = args.old
            results["surveys"][name] = entry
            print(name, json.dumps(entry, indent=1))
    atomic_write_text(RESULTS, json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
