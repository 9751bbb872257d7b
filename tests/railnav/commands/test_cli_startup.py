"""Start-up of the command line: help and argument errors import no heavy machinery.

Each case runs ``railnav.cli.main`` in a fresh interpreter (a subprocess: this test
session has long imported everything) and reads ``sys.modules`` afterwards. Reference:
the modules a call may not import — CasADi, SciPy and the engine (``ekf`` beyond its
errors) for any parse or flag error; with ``--help``, also pandas and matplotlib (the bulk
of a cold start). How fast that is belongs to ``benchmarks/bench_speed.py``, not here.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
PAPER = str(REPO / "data" / "tracks" / "paper2017.csv")

#: Run main(argv) silently, then report the exit status and the heavy modules loaded.
PROBE = """
import contextlib, io, json, sys
from railnav.cli import main
argv = json.loads(sys.argv[1])
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
heavy = ("casadi", "scipy", "pandas", "matplotlib")
print(json.dumps({"code": code,
                  "heavy": sorted(m for m in sys.modules if m.split(".")[0] in heavy
                                  and "." not in m),
                  "engine": sorted(m for m in sys.modules
                                   if m.startswith("ekf.") and m != "ekf.errors")}))
"""

#: Never imported by parsing or by a flag error.
FORBIDDEN = {"casadi", "scipy"}
#: Never imported by --help either.
FORBIDDEN_HELP = FORBIDDEN | {"pandas", "matplotlib"}


def _probe(argv: list[str]) -> dict:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])}
    done = subprocess.run([sys.executable, "-c", PROBE, json.dumps(argv)], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=120, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("argv", [
    ["--help"], ["run", "--help"], ["simulate", "--help"], ["spp", "--help"],
    ["reproduce", "--help"], ["study", "--help"], ["track", "--help"],
    ["track", "fit", "--help"],
], ids=" ".join)
def test_help_imports_no_heavy_module(argv):
    report = _probe(argv)
    assert report["code"] == 0
    assert not FORBIDDEN_HELP & set(report["heavy"]), report
    assert report["engine"] == [], report


@pytest.mark.parametrize("argv", [
    [],                                                     # no command
    ["run"],                                                # no track
    ["run", PAPER, "--filter", "kalman"],                   # not a filter kind
    ["run", PAPER, "--imu-grade", "consumer"],              # not an IMU grade
    ["run", PAPER, "--scenario", "nowhere"],                # not a scenario
    ["run", PAPER, "--crossing-rate-per-s", "-1"],          # a bad number
    ["run", PAPER, "--start-gps-time-s", "1e9"],            # a flag that cannot apply
    ["simulate", PAPER, "--imu-grade", "consumer", "--out", "x"],
], ids=lambda argv: " ".join(argv).replace(PAPER, "paper2017.csv") or "(none)")
def test_argument_errors_import_no_engine(argv):
    report = _probe(argv)
    assert report["code"] == 2
    assert not FORBIDDEN & set(report["heavy"]), report
    assert report["engine"] == [], report
