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
