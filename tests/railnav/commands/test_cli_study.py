"""``railnav study``: outputs, resume message, and one-line errors with exit status 2.

References: the files the command must write (ARCHITECTURE.md's CLI contract), the row
count of the tiny grid (16), and the study's own table read back from results.parquet.
"""
from __future__ import annotations

import pandas as pd

from railnav.cli import main
from railnav.studies import execution as study_exec
from tests.conftest import DATA

TINY = DATA / "studies" / "tiny.toml"


def test_study_command_writes_the_table_and_resumes(tmp_path, capsys):
    out = tmp_path / "study"
    assert main(["-q", "study", str(TINY), "--out", str(out), "--workers", "1"]) == 0
    printed = capsys.readouterr().out
    assert f"16 runs (0 already done, 0 failed) -> {out / 'results.parquet'}" in printed
    table = pd.read_parquet(out / "results.parquet")
    assert len(table) == 16 and table["run_id"].is_unique
    assert {p.name for p in out.iterdir()} == {     # .lock: the study's lock (issue 18)
        "parts", "results.parquet", "study.json", "error_growth_along_track.png",
        "error_growth_horizontal.png", ".lock"}
    assert main(["-q", "study", str(TINY), "--out", str(out), "--no-plots"]) == 0
    assert "16 runs (16 already done, 0 failed)" in capsys.readouterr().out


def test_out_is_a_file(tmp_path, capsys):
    target = tmp_path / "file"
    target.write_text("x")
    assert main(["-q", "study", str(TINY), "--out", str(target)]) == 2
    assert capsys.readouterr().err == f"error: {target}: exists and is not a directory\n"


def test_out_holding_other_files_is_refused(tmp_path, capsys):
    """A study resumes in its own folder; a non-empty folder that is not a study's (no
    study.json, parts or lock) is someone else's: one line naming it, exit 2, and the
    folder is left as it was (the tiny study had written its parts, table, plots and
    lock beside the file)."""
    target = tmp_path / "notes"
    target.mkdir()
    (target / "notes.txt").write_text("mine")
    assert main(["-q", "study", str(TINY), "--out", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {target}: ") and "not a study" in err
    assert err.count("\n") == 1
    assert [p.name for p in target.iterdir()] == ["notes.txt"]


def test_unreachable_scheduler(tmp_path, capsys, monkeypatch):
    """Nothing listens on port 1: one line, exit 2 (the wait shortened for the test)."""
    monkeypatch.setattr(study_exec, "CONNECT_TIMEOUT_S", 1.0)
    status = main(["-q", "study", str(TINY), "--out", str(tmp_path / "o"),
                   "--scheduler", "tcp://127.0.0.1:1"])
    err = capsys.readouterr().err
    assert status == 2
    assert err.startswith("error: cannot reach the Dask scheduler 'tcp://127.0.0.1:1'")
    assert err.count("\n") == 1


def test_missing_config_file(tmp_path, capsys):
    missing = tmp_path / "none.toml"
    assert main(["-q", "study", str(missing), "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.startswith(f"error: {missing}: ")
