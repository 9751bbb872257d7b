"""A study's results on disk: atomic parquet parts, resume, and the final merged table.

Finished rows are written in parts (``DIR/parts/part-<session>-<n>.parquet``), each to a
temporary file renamed into place (`trackmodel.files.atomic_write`): a part is on disk
whole or not at all, so an interrupted study (Ctrl-C, a killed process, a lost machine)
never leaves a half-written part. On restart `PartStore.finished_ids` lists the run ids
already written and those runs are skipped. `PartStore.merge` reads every part, keeps
each requested run id once, orders the rows by run index and writes ``results.parquet``
(again atomically).
"""
from __future__ import annotations

import logging
import uuid
from pathlib import Path

import pandas as pd

from trackmodel.files import atomic_write

__all__ = ["PartStore", "PARTS_DIR", "RESULTS_FILE"]

log = logging.getLogger(__name__)

#: Folder of the parts inside a study's output folder.
PARTS_DIR = "parts"
#: The merged table inside a study's output folder.
RESULTS_FILE = "results.parquet"
_PART_GLOB = "part-*.parquet"


class PartStore:
    """The parts folder of one study output folder.

    Parameters
    ----------
    out_dir : path
        The study's output folder (created with its ``parts`` folder).
    """

    def __init__(self, out_dir: str | Path) -> None:
        self.out_dir = Path(out_dir)
        self.parts_dir = self.out_dir / PARTS_DIR
        self.parts_dir.mkdir(parents=True, exist_ok=True)
        self.session = uuid.uuid4().hex[:12]
        self._count = 0

    def part_paths(self) -> list[Path]:
        """The complete parts on disk, in name order (temporary files are not parts)."""
        return sorted(self.parts_dir.glob(_PART_GLOB))

    def read(self) -> pd.DataFrame:
        """Every row written so far (a run id at most once: the first part's row)."""
        frames = [pd.read_parquet(p) for p in self.part_paths()]
        frames = [f for f in frames if len(f)]
        if not frames:
            return pd.DataFrame({"run_id": pd.Series([], dtype=str)})
        table = pd.concat(frames, ignore_index=True)
        return table.drop_duplicates("run_id", keep="first", ignore_index=True)

    def finished_ids(self) -> set[str]:
        """Run ids already written."""
        ids: set[str] = set()
        for path in self.part_paths():
            ids.update(pd.read_parquet(path, columns=["run_id"])["run_id"])
        return ids

    def write(self, rows: list[dict]) -> Path | None:
        """Write `rows` as a new part (atomically); None when there are none."""
        if not rows:
            return None
        self._count += 1
        path = self.parts_dir / f"part-{self.session}-{self._count:05d}.parquet"
        with atomic_write(path, "wb") as fh:
            pd.DataFrame(rows).to_parquet(fh, index=False)
        log.debug("wrote %d rows to %s", len(rows), path.name)
        return path

    def merge(self, run_ids: list[str], columns: list[str]) -> tuple[pd.DataFrame, Path]:
        """The rows of `run_ids` (in that order) with `columns` first, written to
        ``results.parquet``; runs not written yet are absent."""
        table = self.read()
        order = {rid: k for k, rid in enumerate(run_ids)}
        table = table[table["run_id"].isin(order)]
        table = table.iloc[table["run_id"].map(order).argsort(kind="stable")]
        rest = [c for c in table.columns if c not in columns]
        table = table.reindex(columns=[c for c in columns if c in table.columns] + rest)
        table = table.reset_index(drop=True)
        path = self.out_dir / RESULTS_FILE
        with atomic_write(path, "wb") as fh:
            table.to_parquet(fh, index=False)
        return table, path
