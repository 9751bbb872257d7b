"""``railnav reproduce`` in-process: JSON file, printed table, bad arguments → exit 2.

Reference for the printed numbers: the JSON the same command wrote (to the table's 4
significant digits)."""
from __future__ import annotations

import json

import pytest

from railnav.cli import main

#: The table prints 4 significant digits.
PRINT_RTOL = 5e-4


def test_reproduce_writes_json_and_prints_table(tmp_path, capsys):
    code = main(["-q", "reproduce", "anomaly2021", "--runs", "1", "--seed", "2",
                 "--out", str(tmp_path)])
    assert code == 0
    doc = json.loads((tmp_path / "anomaly2021.json").read_text())
    assert {"paper", "with_test", "without_test", "with_test_gamma4"} <= doc.keys()
    assert (doc["runs"], doc["seed"]) == (1, 2)
    assert doc["paper"]["without_test"]["height_m"] == {"value": 140.0, "relation": "about"}
    out = capsys.readouterr().out
    line = next(s for s in out.splitlines()
                if s.split()[:3] == ["height", "m", "without_test"])
    median = float(line.split()[-2])
    assert median == pytest.approx(doc["without_test"]["height_m"]["median"], rel=PRINT_RTOL)
    assert "≈140" in line
    assert [p.name for p in tmp_path.iterdir()] == ["anomaly2021.json"]


@pytest.mark.parametrize("args", [["nope"], ["anomaly2021", "--runs", "0"],
                                  ["anomaly2021", "--runs", "x"],
                                  ["anomaly2021", "--seed", "-1"]])
def test_bad_arguments_exit_2(args, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["-q", "reproduce", *args])
    assert exc.value.code == 2
    assert "error" in capsys.readouterr().err


def test_output_path_that_is_a_file_gives_one_line_and_exit_2(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    code = main(["-q", "reproduce", "anomaly2021", "--runs", "1", "--out", str(blocker)])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:")
    assert blocker.read_text() == "not a directory"


def test_issue18_default_out_is_not_the_working_directory(tmp_path, monkeypatch, capsys):
    """``reproduce`` wrote EXPERIMENT.json into the current directory; now into its own
    folder, as ``run`` (railnav-run) and ``study`` (railnav-study) do, and says so."""
    from railnav.commands.reproduce import DEFAULT_OUT
    monkeypatch.chdir(tmp_path)
    assert main(["-q", "reproduce", "anomaly2021", "--runs", "1"]) == 0
    assert [p.name for p in tmp_path.iterdir()] == [DEFAULT_OUT]
    written = tmp_path / DEFAULT_OUT / "anomaly2021.json"
    assert json.loads(written.read_text())["runs"] == 1
    assert f"written: {DEFAULT_OUT}" in capsys.readouterr().out
