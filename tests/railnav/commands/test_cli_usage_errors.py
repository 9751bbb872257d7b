"""A bad option value or a missing argument is a usage error: one line on stderr that
names the option and the problem (and where the command's help is), exit status 2, no
traceback and nothing written; as every other input error of the command line
(`railnav.cli`). Argparse's own ``error`` printed the whole usage block first (18 lines
for ``simulate``, 32 for ``run``) before its message."""
from __future__ import annotations

import pytest

from railnav.cli import main
from railnav.simulation.scenarios import TRACKS_DIR

CURVY = str(TRACKS_DIR / "curvy.csv")


@pytest.mark.parametrize("argv, prog, words", [
    (["simulate", CURVY, "--duration-s", "-5"], "railnav simulate", ["--duration-s", "'-5'"]),
    (["simulate", CURVY, "--scenario", "foo"], "railnav simulate", ["--scenario", "'foo'"]),
    (["run", CURVY, "--outage", "100-50"], "railnav run", ["--outage", "'100-50'"]),
    (["run", CURVY, "--window", "1000:900"], "railnav run", ["--window", "'1000:900'"]),
    (["run", CURVY, "--imu-grade", "consumer"], "railnav run", ["--imu-grade", "'consumer'"]),
    (["reproduce", "paper2018"], "railnav reproduce", ["EXPERIMENT", "'paper2018'"]),
    (["track", "fit", CURVY], "railnav track fit", ["--out", "required"]),
    (["network", "routes", "N", "--start", "E:abc"], "railnav network routes",
     ["--start", "'E:abc'"]),
    (["spp", "--nav", "n.rnx"], "railnav spp", ["--obs", "required"]),
    (["teleport"], "railnav", ["COMMAND", "'teleport'"]),
])
def test_a_usage_error_is_one_line(tmp_path, capsys, argv, prog, words):
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--out", str(out)] if argv[0] in ("simulate", "run") else argv)
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert exc.value.code == 2
    assert len(lines) == 1, captured.err
    line = lines[0]
    assert line.startswith("error: ") and f"({prog} --help)" in line
    assert all(w in line for w in words), line
    assert "Traceback" not in captured.err and captured.out == ""
    assert not out.exists()


def test_help_still_shows_the_usage(capsys):
    """``--help`` is not an error: the usage and every option, exit 0."""
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--help"])
    text = capsys.readouterr().out
    assert exc.value.code == 0 and text.startswith("usage: railnav simulate")
    assert "--duration-s" in text
