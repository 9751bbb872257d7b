"""The ``railnav`` command as a process (`railnav.cli.console_main`): it ends without the
interpreter's teardown, so its exit status and everything it printed to a pipe (block
buffered) must still come out, as `main` returned and printed them in-process."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from railnav.simulation.scenarios import TRACKS_DIR

REPO = Path(__file__).resolve().parents[3]


def _railnav(*argv: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO), "MPLBACKEND": "Agg"}
    return subprocess.run([sys.executable, "-m", "railnav.cli", *argv], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=600)


def test_a_run_prints_its_report_and_exits_0(tmp_path):
    out = tmp_path / "run"
    done = _railnav("-q", "run", str(TRACKS_DIR / "paper2017.csv"), "--duration-s", "10",
                    "--no-plots", "--out", str(out))
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("constrained filter: 1000 steps")
    assert lines[-1] == f"{out}{os.sep}: estimates.csv, innovations.csv, errors.csv, summary.json"


def test_bad_input_prints_one_line_and_exits_2(tmp_path):
    missing = tmp_path / "missing.csv"
    done = _railnav("run", str(missing), "--out", str(tmp_path / "run"))
    assert done.returncode == 2
    assert done.stderr.strip().splitlines()[-1] == f"error: {missing}: No such file or directory"


def test_quiet_keeps_the_report_and_drops_info_logs(tmp_path):
    """Audit finding: ``-q``'s help said 'warnings and errors only' while every command
    still printed its report. The report on stdout is the command's result and is kept;
    the help of every command now says so, and ``-q`` drops the info logs ``-v`` asks
    for (a fix-started run logs where it started)."""
    from railnav.cli import QUIET_HELP, _subparsers, build_parser
    parser = build_parser()
    for sub in [parser, *_subparsers(parser)]:
        quiet = next(a for a in sub._actions if "-q" in a.option_strings)
        assert quiet.help == QUIET_HELP and "report on stdout is still printed" in quiet.help
    track = str(TRACKS_DIR / "curvy.csv")
    sim = tmp_path / "sim"
    assert _railnav("-q", "simulate", track, "--duration-s", "20", "--no-gnss",
                    "--fixes-format", "csv", "--out", str(sim)).returncode == 0
    runs = {flags: _railnav(*flags, "run", track, "--fixes", str(sim / "fixes.csv"),
                            "--no-plots", "--out", str(tmp_path / "-".join(flags)))
            for flags in (("-v",), ("-q", "-v"))}
    assert "INFO" in runs[("-v",)].stderr and "started at t=" in runs[("-v",)].stderr
    assert runs[("-q", "-v")].stderr == ""
    for done in runs.values():
        assert done.stdout.startswith("gnss-only filter: ")
