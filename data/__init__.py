"""The data railnav ships: tracks, networks, studies, GNSS excerpts and a baro example
(installed as `railnav_data`).

The repository keeps them in its top-level ``data/`` folder; the wheel carries that folder
as the package `railnav_data`, so code finds a shipped file the same way in a checkout, an
editable install and a wheel installed anywhere: ``shipped_path("tracks", "curvy.csv")``.
Each subfolder's README gives the provenance of its files.
"""
from __future__ import annotations

from importlib.resources import files
from pathlib import Path

__all__ = ["shipped_path", "TRACKS", "STUDIES", "GNSS", "NETWORKS", "BARO"]

#: Subfolders.
TRACKS, STUDIES, GNSS, NETWORKS, BARO = "tracks", "studies", "gnss", "networks", "baro"


def shipped_path(*parts: str) -> Path:
    """The path of a shipped file or folder, e.g. ``shipped_path("tracks", "curvy.csv")``.

    Installed packages are plain folders (never zipped), so this is a real path.
    """
    return Path(str(files(__name__).joinpath(*parts)))
