"""The folder of the full urban drive, for the benchmarks on real data (``--data DIR``).

The repository ships only a 3-minute excerpt of the drive (``data/gnss/``, provenance in its
README). The benchmarks on the whole 8 minutes read the original files from a folder the
user names; there is no default, so nothing outside the repository is read unasked.
"""
from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_data_argument", "checked_data_dir", "read_drive", "DATASET"]

#: Where the files come from (data/gnss/README.md).
DATASET = ("the dataset mosaicx5_multi_dynamic of the PyPI package gnss-benchmark 2.3.0 "
           "(Rokubun, MIT), see data/gnss/README.md")


def add_data_argument(parser: argparse.ArgumentParser, names: tuple[str, ...]) -> None:
    """Add the required ``--data DIR`` option, documenting the files it must hold."""
    parser.add_argument("--data", type=Path, required=True, metavar="DIR",
                        help=f"folder with {', '.join(names)}: {DATASET}")


def checked_data_dir(parser: argparse.ArgumentParser, data: Path,
                     names: tuple[str, ...]) -> Path:
    """`data` if it holds every file of `names`; else the parser's one-line error (exit 2)."""
    missing = [n for n in names if not (data / n).is_file()]
    if missing:
        parser.error(f"--data {data}: missing {', '.join(missing)} (expected the files of "
                     f"{DATASET})")
    return data


def read_drive(data: Path):
    """The drive's rover observations (``rover_obs.rnx``), broadcast navigation
    (``broadcast_nav.rnx``) and reference trajectory (``reference_trajectory.csv``) in the
    folder `data`: ``(obs, nav, reference)``."""
    from gnss_obs.rinex_nav import read_rinex_nav
    from gnss_obs.rinex_obs import read_rinex_obs
    from railnav.evaluation.spp_accuracy import read_reference_trajectory
    return (read_rinex_obs(data / "rover_obs.rnx"), read_rinex_nav(data / "broadcast_nav.rnx"),
            read_reference_trajectory(data / "reference_trajectory.csv"))
