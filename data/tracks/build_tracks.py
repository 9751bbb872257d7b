"""Rebuild the example track files of this folder (run from the repository root).

    python data/tracks/build_tracks.py            # paper2017, curvy, east_west, double_a/b
    python data/tracks/build_tracks.py --fit      # also refit barcelona_drive (~6 s) to the
                                                  # shipped barcelona_drive_survey.csv
    python data/tracks/build_tracks.py --fit --data DIR
                                                  # first cut the survey again from
                                                  # DIR/reference_trajectory.csv

``DIR`` is the folder of the full urban drive (the dataset ``mosaicx5_multi_dynamic`` of the
PyPI package ``gnss-benchmark`` 2.3.0); nothing outside this repository is read without it.
See README.md here for what each file is and where the surveyed path comes from.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from trackmodel.earth import WGS84, sphere
from trackmodel.fit import fit_track
from trackmodel.io import write_track
from trackmodel.offset import offset_track
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

HERE = Path(__file__).resolve().parent
GRADE_2PC_DEG = math.degrees(math.atan(0.02))
#: The surveyed points barcelona_drive.csv is fitted to (shipped beside it).
SURVEY = HERE / "barcelona_drive_survey.csv"
#: The full drive's reference, inside the folder given as --data.
REFERENCE_NAME = "reference_trajectory.csv"
#: The drive turns round after this row of reference_trajectory.csv (0-based, GPS SoW
#: 46008) and comes back along its own path in the other lane: the first leg is the track.
LAST_ROW_FIRST_LEG = 394


def paper2017() -> Track:
    """Dolgiy et al. 2017: one straight section, A = π/6, ϑ = π/60, sphere, 25 km."""
    return Track([Section(25_000.0, 30.0, 3.0)], Origin(50.45, 30.52, 100.0),
                 sphere(6_371_000.0))


def _curve(radius_m: float, turn_deg: float, transition_m: float, right: bool) -> list[Section]:
    """Clothoid in, arc, clothoid out, turning `turn_deg` in total."""
    k = (1.0 if right else -1.0) / radius_m
    arc_m = math.radians(turn_deg) * radius_m - transition_m   # each transition turns L k/2
    return [Section(transition_m, None, None, 0.0, k), Section(arc_m, None, None, k),
            Section(transition_m, None, None, k, 0.0)]


def _vertical(length_m: float, to_deg: float) -> list[Section]:
    return [Section(length_m, None, None, elevation_end_deg=to_deg)]


def _straight(length_m: float) -> list[Section]:
    return [Section(length_m, None, None)]


def curvy() -> Track:
    """A ~30 km main line: straights, 600–2000 m curves with clothoids, ±2 % grades."""
    g = GRADE_2PC_DEG
    sections = ([Section(2500.0, 75.0, 0.0)] + _vertical(300.0, g) + _straight(1500.0)
                + _curve(1200.0, 25.0, 120.0, True) + _straight(1800.0)
                + _vertical(400.0, -0.5 * g) + _straight(2200.0)
                + _curve(600.0, 40.0, 150.0, False) + _straight(900.0)
                + _vertical(500.0, -g) + _straight(2600.0)
                + _curve(2000.0, 12.0, 90.0, True) + _straight(1200.0)
                + _vertical(300.0, 0.0) + _straight(3000.0)
                + _curve(800.0, 35.0, 130.0, True) + _straight(1500.0)
                + _curve(1500.0, 20.0, 100.0, False) + _vertical(400.0, g)
                + _straight(2500.0) + _vertical(300.0, 0.0) + _straight(5000.0))
    return Track(sections, Origin(48.10, 11.50, 520.0), WGS84)


def east_west() -> Track:
    """Due east (azimuth exactly 90°) for 10 km, a 180° curve, then west (270°)."""
    sections = ([Section(10_000.0, 90.0, 0.3)] + _curve(1000.0, 180.0, 100.0, True)
                + _straight(5_000.0))
    return Track(sections, Origin(45.0, 7.0, 250.0), WGS84)


#: Distance between the centre lines of the two tracks of the double line, m (4.5 m: the
#: track spacing of new main lines, e.g. EN 15273 / DB Ril 800.0130 for up to 200 km/h).
DOUBLE_TRACK_SPACING_M = 4.5


def double_line() -> tuple[Track, Track]:
    """A ~23 km double line: track A, and track B 4.5 m to its right (`offset_track`).

    Six curves of radius 600–2000 m with clothoids, both hands, two of them on ±1 %
    grades; grades joined by vertical curves on straights.
    """
    g = math.degrees(math.atan(0.01))
    sections = ([Section(2000.0, 40.0, 0.0)] + _vertical(300.0, g) + _straight(1000.0)
                + _curve(800.0, 30.0, 120.0, True) + _straight(1500.0)
                + _vertical(300.0, 0.0) + _straight(1200.0)
                + _curve(1200.0, 45.0, 100.0, False) + _straight(2000.0)
                + _curve(600.0, 25.0, 150.0, True) + _straight(1800.0)
                + _vertical(300.0, -g) + _curve(2000.0, 15.0, 90.0, False)
                + _straight(2500.0) + _vertical(300.0, 0.0)
                + _curve(1000.0, 35.0, 110.0, True) + _straight(4000.0)
                + _curve(700.0, 20.0, 120.0, False) + _straight(3000.0))
    track_a = Track(sections, Origin(49.0, 9.0, 300.0), WGS84)
    return track_a, offset_track(track_a, DOUBLE_TRACK_SPACING_M)


def barcelona_survey(data: Path) -> pd.DataFrame:
    """The first leg of the urban drive's reference trajectory, in `data` (module docstring)."""
    ref = pd.read_csv(data / REFERENCE_NAME)
    ref.columns = ["gps_week", "gps_sow_s", "lat_deg", "lon_deg", "h_m", "sdn_m", "sde_m",
                   "sdu_m"]
    return ref.iloc[:LAST_ROW_FIRST_LEG + 1][["gps_week", "gps_sow_s", "lat_deg", "lon_deg",
                                               "h_m"]]


def _arguments(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fit", action="store_true",
                        help="also refit barcelona_drive.csv to barcelona_drive_survey.csv")
    parser.add_argument("--data", type=Path, default=None, metavar="DIR",
                        help=f"with --fit: cut barcelona_drive_survey.csv again from "
                             f"DIR/{REFERENCE_NAME} (the full urban drive)")
    args = parser.parse_args(argv)
    if args.data is not None:
        if not args.fit:
            parser.error("--data is used only with --fit")
        if not (args.data / REFERENCE_NAME).is_file():
            parser.error(f"--data {args.data}: no {REFERENCE_NAME} there (the folder of the "
                         "urban drive, dataset mosaicx5_multi_dynamic of gnss-benchmark 2.3.0)")
    return args


def main(argv: list[str]) -> None:
    args = _arguments(argv)
    write_track(paper2017(), HERE / "paper2017.csv",
                comments=["Dolgiy, Rozenberg, Bayandurova 2017: A = pi/6, theta = pi/60, "
                          "1000 s at 20 m/s + margin; origin Kyiv (see README.md)"])
    write_track(curvy(), HERE / "curvy.csv",
                comments=["synthetic main line, built by data/tracks/build_tracks.py"])
    write_track(east_west(), HERE / "east_west.csv",
                comments=["east-west edge case: azimuth exactly 90 deg, then a U curve"])
    track_a, track_b = double_line()
    write_track(track_a, HERE / "double_a.csv",
                comments=["double line, track A: built by data/tracks/build_tracks.py"])
    write_track(track_b, HERE / "double_b.csv",
                comments=[f"double line, track B: {DOUBLE_TRACK_SPACING_M} m to the right of "
                          "double_a.csv (trackmodel.offset.offset_track)"])
    if args.fit:
        if args.data is not None:
            barcelona_survey(args.data).to_csv(SURVEY, index=False)
        survey = pd.read_csv(SURVEY)
        result = fit_track(np.radians(survey.lat_deg), np.radians(survey.lon_deg),
                           survey.h_m.to_numpy(), tol_m=0.5, vtol_m=1.0)
        write_track(result.track, HERE / "barcelona_drive.csv", comments=[
            "fitted (tol_m=0.5, vtol_m=1.0) to barcelona_drive_survey.csv: the PPK reference "
            "trajectory of gnss-benchmark 2.3.0 mosaicx5_multi_dynamic (Rokubun, MIT), "
            f"rows 0-{LAST_ROW_FIRST_LEG}; {result.n_sections} sections, max horizontal "
            f"deviation {result.max_horizontal_m:.3f} m"])
        print(f"barcelona: {result.n_sections} sections, "
              f"max {result.max_horizontal_m:.3f} m")


if __name__ == "__main__":
    main(sys.argv[1:])
