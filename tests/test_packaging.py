"""What the wheel carries: every package of the tree, and every shipped data file.

The wheel's content is set by ``pyproject.toml`` (an explicit package list, and the data
folder ``data/`` mapped to the package ``railnav_data``); these tests hold that list
against the folders, so a new subpackage or data file cannot be left out silently.
``.ci/run`` builds the wheel and runs the main job from it outside the repository.
"""
from __future__ import annotations

import fnmatch
import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:                                   # pragma: no cover - Python 3.10
    import tomli as tomllib

from railnav_data import GNSS, NETWORKS, STUDIES, TRACKS, shipped_path

REPO = Path(__file__).resolve().parents[1]
CODE = ("trackmodel", "strapdown", "gnss_obs", "ekf", "railnav")


def _setuptools() -> dict:
    return tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]


def test_every_package_folder_is_listed():
    listed = set(_setuptools()["packages"])
    found = {".".join(p.parent.relative_to(REPO).parts)
             for top in CODE for p in (REPO / top).rglob("__init__.py")}
    assert listed == found | {"railnav_data"}


def test_data_maps_to_railnav_data_and_every_shipped_file_is_included():
    config = _setuptools()
    assert config["package-dir"] == {"railnav_data": "data"}
    patterns = config["package-data"]["railnav_data"]
    folders = sorted(p.name for p in (REPO / "data").iterdir()
                     if p.is_dir() and p.name != "__pycache__")
    assert {TRACKS, STUDIES, GNSS} <= set(folders)
    shipped = [p.relative_to(REPO / "data").as_posix()
               for p in (REPO / "data").rglob("*") if p.is_file() and p.suffix not in
               (".py", ".pyc") and p.parent != REPO / "data"]
    assert {f.split("/")[0] for f in shipped} >= {TRACKS, STUDIES, GNSS, NETWORKS, "fixes"}
    assert len(shipped) > 15
    missing = [f for f in shipped if not any(fnmatch.fnmatch(f, pat) for pat in patterns)]
    assert missing == []


def test_shipped_path_finds_the_files_of_this_checkout():
    assert shipped_path(TRACKS, "paper2017.csv") == REPO / "data" / "tracks" / "paper2017.csv"
    assert shipped_path(GNSS, "broadcast_nav.rnx").is_file()
