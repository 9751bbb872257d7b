"""Fitted track networks as folders: ``connections.csv`` (``a, a_end, b, b_end,
navigability``) plus one track file per netelement in ``elements/`` (`trackmodel.io`),
listed in ``elements.csv`` (``element, file``, then any attribute columns; empty cells are
absent attributes). `trackmodel.network_io` re-exports `write_network` and `read_network`.

**Heights** (`trackmodel.network.Network` ``heights``): a track file always has heights,
so a network without them says so in the column `HEIGHTS_COLUMN` of ``elements.csv``:
``no`` on its netelements (empty or ``yes``: it has them; a folder without the column has
heights). `heights_known` is the rule every network source follows: a network has heights
when every netelement has them; when only some have, it is read without heights with one
warning (a run cannot have a height on some netelements and none on others).
"""
from __future__ import annotations

import logging
import os
import re
import shutil
import tempfile
from collections.abc import Collection
from pathlib import Path

import pandas as pd

from trackmodel.errors import TrackError, TrackFileError
from trackmodel.files import atomic_write_csv
from trackmodel.io import read_track, write_track
from trackmodel.network import Connection, Network

__all__ = ["write_network", "read_network", "heights_known", "HEIGHTS_COLUMN"]

log = logging.getLogger(__name__)

#: Column of ``elements.csv`` saying whether a netelement has heights (module docstring).
HEIGHTS_COLUMN = "heights"


def heights_known(with_heights: Collection, count: int, where) -> bool:
    """Whether a network of `count` netelements has heights, `with_heights` being those of
    them that have (module docstring); one warning naming `where` when only some have."""
    if with_heights and len(with_heights) < count:
        log.warning("%s: %d of %d netelements have heights, the others not: the network is "
                    "read without heights", where, len(with_heights), count)
    return len(with_heights) == count


def _file_name(element: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", element) + ".csv"


def write_network(network: Network, folder: str | os.PathLike) -> None:
    """Write a fitted network as a folder (module docstring). The folder is written
    beside the target and moved into place at the end, so an error leaves nothing
    half-written; an existing network folder there is replaced.

    Raises
    ------
    TrackError
        `folder` exists and is neither empty nor a network folder, or two netelement ids
        map to one file name.
    """
    out = Path(folder)
    if out.exists() and not (out.is_dir() and (not any(out.iterdir())
                                               or (out / "elements.csv").is_file())):
        raise TrackError(f"{out}: exists and is not a network folder")
    files = {name: _file_name(name) for name in network.elements}
    if len(set(files.values())) != len(files):
        raise TrackError("two netelement ids map to one file name")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        _write_folder(network, tmp, files)
        if out.exists():
            old = out.with_name(f".{out.name}.old-{tmp.name}")
            out.rename(old)
            tmp.rename(out)
            shutil.rmtree(old)
        else:
            tmp.rename(out)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp)


def _write_folder(network: Network, out: Path, files: dict[str, str]) -> None:
    (out / "elements").mkdir()
    for name, track in network.elements.items():
        write_track(track, out / "elements" / files[name], comments=[f"netelement {name}"])
    index = pd.DataFrame({"element": list(files),
                          "file": [f"elements/{f}" for f in files.values()]})
    if not network.heights:
        index[HEIGHTS_COLUMN] = "no"
    keys = sorted({k for values in network.attributes.values() for k in values} - {*index})
    for key in keys:
        index[key] = [network.attributes.get(name, {}).get(key, "") for name in files]
    atomic_write_csv(out / "elements.csv", index)
    atomic_write_csv(out / "connections.csv", pd.DataFrame(
        [{"a": c.a, "a_end": c.a_end, "b": c.b, "b_end": c.b_end,
          "navigability": c.navigability} for c in network.connections],
        columns=["a", "a_end", "b", "b_end", "navigability"]))


def read_network(folder: str | os.PathLike) -> Network:
    """A network written by `write_network`.

    Raises
    ------
    TrackFileError
        A missing or malformed file (located).
    """
    root = Path(folder)
    index = _csv(root / "elements.csv", ("element", "file"))
    elements, attributes, heights = {}, {}, {}
    for i, row in enumerate(index.to_dict("records"), start=1):
        name, file = row.pop("element"), row.pop("file")
        heights[name] = _heights_cell(row.pop(HEIGHTS_COLUMN, ""), root / "elements.csv", i)
        if not name or name in elements:
            raise TrackFileError(f"netelement {name!r} empty or given twice",
                                 path=root / "elements.csv", row=i)
        try:
            target = (root / file).resolve()
            inside = root.resolve() in target.parents and target.is_file()
        except (OSError, ValueError):                 # a NUL byte, a loop of links
            inside = False
        if not inside:
            raise TrackFileError(f"file {file!r} is not a file inside the network folder",
                                 path=root / "elements.csv", row=i)
        elements[name] = read_track(target)
        attributes[name] = {k: v for k, v in row.items() if v != ""}
    table = _csv(root / "connections.csv", ("a", "a_end", "b", "b_end", "navigability"))
    connections = []
    for i, row in enumerate(table.itertuples(), start=1):
        try:
            a_end, b_end = int(row.a_end), int(row.b_end)
        except (TypeError, ValueError):
            raise TrackFileError("a_end and b_end must be 0 or 1", path=root / "connections.csv",
                                 row=i) from None
        connections.append(Connection(str(row.a), a_end, str(row.b), b_end,
                                      str(row.navigability)))
    known = [name for name, given in heights.items() if given]
    try:
        return Network(elements, connections, attributes,
                       heights=heights_known(known, len(elements), root / "elements.csv"))
    except TrackError as exc:
        raise TrackFileError(str(exc), path=root / "connections.csv") from None


def _heights_cell(text: str, path: Path, row: int) -> bool:
    """Whether a netelement of a folder has heights: ``heights`` = ``yes`` or empty (the
    default), or ``no``."""
    if text not in ("", "yes", "no"):
        raise TrackFileError(f"{HEIGHTS_COLUMN} must be yes, no or empty, got {text!r}",
                             path=path, row=row, column=HEIGHTS_COLUMN)
    return text != "no"


def _csv(path: Path, columns: tuple[str, ...]) -> pd.DataFrame:
    try:
        frame = pd.read_csv(path, dtype=str, keep_default_na=False)
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise TrackFileError(f"cannot read ({exc})", path=path) from None
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise TrackFileError(f"missing column(s) {', '.join(missing)}", path=path)
    return frame
