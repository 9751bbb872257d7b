"""Issue 18: `trackmodel.files.output_directory`, the one owner of atomic output folders."""
from __future__ import annotations

import os
import stat
import subprocess
import sys

import pytest

from trackmodel.errors import InputError
from trackmodel.files import output_directory


def test_issue18_written_whole_with_the_umask_permissions(tmp_path):
    out = tmp_path / "a" / "b"              # parents created
    with output_directory(out) as tmp:
        assert tmp.parent == out.parent and tmp.name.startswith(".b.tmp-")
        (tmp / "x.txt").write_text("x")
        assert not out.exists()             # nothing visible before the end
    assert [p.name for p in out.iterdir()] == ["x.txt"]
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(out.stat().st_mode) == 0o777 & ~umask


def test_issue18_an_exception_leaves_the_old_directory(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "old.txt").write_text("old")
    with pytest.raises(RuntimeError):
        with output_directory(out, overwrite=True) as tmp:
            (tmp / "new.txt").write_text("new")
            raise RuntimeError("boom")
    assert [p.name for p in out.iterdir()] == ["old.txt"]
    assert [p.name for p in tmp_path.iterdir()] == ["o"]


def test_issue18_empty_existing_directory_is_used(tmp_path):
    out = tmp_path / "empty"
    out.mkdir()
    with output_directory(out) as tmp:
        (tmp / "x.txt").write_text("x")
    assert [p.name for p in out.iterdir()] == ["x.txt"]


@pytest.mark.parametrize("where", [".", ".."])
def test_issue18_working_directory_is_refused(tmp_path, monkeypatch, where):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "keep.txt").write_text("k")
    with pytest.raises(InputError, match="is the working directory or contains it"):
        with output_directory(where, overwrite=True):
            pass
    assert (tmp_path / "keep.txt").exists()


def test_issue18_a_file_is_refused(tmp_path):
    target = tmp_path / "f"
    target.write_text("f")
    with pytest.raises(InputError, match="exists and is not a directory"):
        with output_directory(target, overwrite=True):
            pass


def test_issue18_stale_siblings_of_dead_processes_are_removed(tmp_path):
    done = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    dead = int(done.stdout)                 # a process that has exited
    stale = tmp_path / f".o.tmp-{dead}-abc"
    stale.mkdir()
    alive = tmp_path / f".o.tmp-{os.getpid()}-xyz"   # this process: kept
    alive.mkdir()
    other = tmp_path / f".other.tmp-{dead}-abc"      # another output's: kept
    other.mkdir()
    with output_directory(tmp_path / "o"):
        pass
    assert not stale.exists() and alive.exists() and other.exists()


@pytest.mark.parametrize("error", [KeyboardInterrupt, PermissionError])
def test_issue18_interrupted_while_the_sibling_is_made(tmp_path, monkeypatch, error):
    """Ctrl-C (or an OSError) after the hidden sibling exists but before the block runs
    (its permissions being set): the sibling goes, nothing is left; an OSError is the
    usual one-line `InputError` naming the destination."""
    import trackmodel.files as files

    def interrupted(path, mode):
        raise error(13, "interrupted here", str(path))
    monkeypatch.setattr(files.os, "chmod", interrupted)
    expected = InputError if error is PermissionError else KeyboardInterrupt
    with pytest.raises(expected):
        with output_directory(tmp_path / "out"):
            pytest.fail("the block must not run")
    assert list(tmp_path.iterdir()) == []
