"""Atomic writes: all or nothing, and ordinary permissions."""
from __future__ import annotations

import os
import stat

import pytest

from trackmodel.files import atomic_write, atomic_write_csv, atomic_write_text


def test_written_file_has_umask_permissions(tmp_path):
    umask = os.umask(0o022)
    try:
        path = tmp_path / "a.txt"
        atomic_write_text(path, "hello")
        assert path.read_text() == "hello"
        assert stat.S_IMODE(path.stat().st_mode) == 0o644   # 0o666 & ~0o022, as open() gives
    finally:
        os.umask(umask)


def test_failure_leaves_previous_content_and_no_temporary(tmp_path):
    path = tmp_path / "b.txt"
    path.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_write(path) as fh:
            fh.write("half")
            raise RuntimeError("boom")
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["b.txt"]


def test_csv_has_no_index_and_the_given_float_format(tmp_path):
    import pandas as pd
    path = tmp_path / "t.csv"
    atomic_write_csv(path, pd.DataFrame({"a": [1.0 / 3.0], "b": [2]}), float_format="%.3g")
    assert path.read_text().splitlines() == ["a,b", "0.333,2"]
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]
