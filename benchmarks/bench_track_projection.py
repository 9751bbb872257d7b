"""Speed of the track model: queries ``Track.at`` and projection of points, in one process.

* a 100 km straight (closed-form loxodrome) and the ~30 km ``data/tracks/curvy.csv``
  (integrated arcs and clothoids, Chebyshev evaluation);
* ``at``: 10⁵ random ``s``; ``project``: 10⁵ points at random offsets (±20 m across,
  ±5 m vertical) — the issue's target is "10⁵ points on a 100 km line in well under a
  second"; the k-d tree is built on the first projection and timed separately;
* the ratio projection / ``at`` (projection = seed + ~2 Newton steps + offsets).

Writes ``benchmarks/results/track_projection.json``.
Run: ``python benchmarks/bench_track_projection.py``.
"""
from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np

from trackmodel.earth import C_n_e, ecef_to_geodetic
from trackmodel.io import read_track
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

ROOT = Path(__file__).resolve().parents[1]
N_POINTS = 100_000


def _best(f, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def bench(track: Track, rng: np.random.Generator, repeat: int) -> dict:
    s = rng.uniform(0.0, track.length_m, N_POINTS)
    pt = track.at(s)
    d_n = np.column_stack([rng.uniform(-20, 20, N_POINTS), rng.uniform(-20, 20, N_POINTS),
                           rng.uniform(-5, 5, N_POINTS)])
    lat, lon, h = ecef_to_geodetic(pt.r_e + np.einsum("...ij,...j->...i",
                                                      C_n_e(pt.lat, pt.lon), d_n))
    t0 = time.perf_counter()
    track.projector                                   # noqa: B018  (build samples + tree)
    build = time.perf_counter() - t0
    t_at = _best(lambda: track.at(s), repeat)
    t_proj = _best(lambda: track.project(lat, lon, h), repeat)
    return {"length_m": track.length_m, "sections": len(track.sections),
            "n_points": N_POINTS, "at_s": t_at, "projector_build_s": build,
            "project_s": t_proj, "project_over_at": t_proj / t_at}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/track_projection.json")
    args = parser.parse_args()
    rng = np.random.default_rng(1)
    straight = Track([Section(100_000.0, 30.0, 0.3)], Origin(50.0, 30.0, 100.0))
    result = {"machine": platform.platform(), "python": platform.python_version(),
              "straight_100km": bench(straight, rng, args.repeat),
              "curvy": bench(read_track(ROOT / "data/tracks/curvy.csv"), rng, args.repeat)}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
