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

REPO = Path(__file__).resolve().parents[3]
PAPER = str(REPO / "data" / "tracks" / "paper2017.csv")

#: Run main(argv) silently for each argv in turn; after each, the exit status and the
#: heavy modules loaded so far (cumulative: a module one call loads shows in the later
#: reports too, and the first report that shows it names the call).
PROBE = """
import contextlib, io, json, sys
from railnav.cli import main
heavy = ("casadi", "scipy", "pandas", "matplotlib")
reports = []
for argv in json.loads(sys.argv[1]):
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code
    reports.append({"argv": argv, "code": code,
                    "heavy": sorted(m for m in sys.modules if m in heavy),
                    "engine": sorted(m for m in sys.modules
                                     if m.startswith("ekf.") and m != "ekf.errors")})
print(json.dumps(reports))
"""

#: Never imported by parsing or by a flag error.
FORBIDDEN = {"casadi", "scipy"}
#: Never imported by --help either.
FORBIDDEN_HELP = FORBIDDEN | {"pandas", "matplotlib"}

HELP = [["--help"], ["run", "--help"], ["simulate", "--help"], ["spp", "--help"],
        ["reproduce", "--help"], ["study", "--help"], ["track", "--help"],
        ["track", "fit", "--help"], ["--version"], ["run", "--help", "-q"]]
ERRORS = [
    [],                                                     # no command
    ["run"],                                                # no track
    ["run", PAPER, "--filter", "kalman"],                   # not a filter kind
    ["run", PAPER, "--imu-grade", "consumer"],              # not an IMU grade
    ["run", PAPER, "--scenario", "nowhere"],                # not a scenario
    ["run", PAPER, "--crossing-rate-per-s", "-1"],          # a bad number
    ["simulate", PAPER, "--imu-grade", "consumer", "--out", "x"],
    ["run", PAPER, "--start-gps-time-s", "1e9"],            # a flag that cannot apply
]


def _fresh(script: str, arg, timeout: float = 120) -> object:
    """Run `script` in a fresh interpreter with `arg` as JSON (its ``sys.argv[1]``); the
    JSON of its last output line."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])}
    done = subprocess.run([sys.executable, "-c", script, json.dumps(arg)], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=timeout, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def _probe(calls: list[list[str]]) -> list[dict]:
    """One fresh interpreter for all `calls` (a subprocess costs ~0.5 s)."""
    return _fresh(PROBE, calls)


def test_help_imports_no_heavy_module():
    for report in _probe(HELP):
        assert report["code"] == 0, report
        assert not FORBIDDEN_HELP & set(report["heavy"]), report
        assert report["engine"] == [], report


def test_argument_errors_import_no_engine():
    for report in _probe(ERRORS):
        assert report["code"] == 2, report
        assert not FORBIDDEN & set(report["heavy"]), report
        assert report["engine"] == [], report


#: What a run of the main job never needs: SciPy's statistics (~0.3 s of imports: its
#: distributions; `scipy.special`'s functions give the same quantiles) and the plots'
#: library without plots.
RUN_FORBIDDEN = ("scipy.stats", "matplotlib")

RUN_PROBE = """
import contextlib, io, json, sys
from railnav.cli import main
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    code = main(json.loads(sys.argv[1]))
print(json.dumps({"code": code, "loaded": sorted(m for m in sys.modules
                                                 if m.startswith(%r))}))
"""


def test_a_run_without_plots_imports_no_statistics_or_plots(tmp_path):
    """A short paper2017 run with --no-plots (the README's main job, in small) never
    loads `RUN_FORBIDDEN` (stop 39: the start's scatter test had pulled in scipy.stats,
    0.29 s of every file run's imports)."""
    argv = ["-q", "run", PAPER, "--duration-s", "20", "--no-plots", "--out",
            str(tmp_path / "o")]
    report = _fresh(RUN_PROBE % (RUN_FORBIDDEN,), argv, timeout=300)
    assert report["code"] == 0 and report["loaded"] == [], report


#: What simulating a trip's files never needs: SciPy (its linear algebra and special
#: functions are the filter's; the simulation is NumPy's and CasADi's) and the plots.
SIMULATE_FORBIDDEN = ("scipy", "matplotlib")


def test_simulating_files_imports_no_scipy(tmp_path):
    """``railnav simulate`` (a short paper2017 trip, GNSS and baro readings too) never loads
    `SIMULATE_FORBIDDEN` (stop 41: the baro model's module had imported the filter's update,
    and with it scipy.linalg and scipy.special, ~0.08 s of every simulation's imports)."""
    argv = ["-q", "simulate", PAPER, "--duration-s", "20", "--baro", "--out",
            str(tmp_path / "o")]
    report = _fresh(RUN_PROBE % (SIMULATE_FORBIDDEN,), argv, timeout=300)
    assert report["code"] == 0 and report["loaded"] == [], report
    assert (tmp_path / "o" / "imu.csv").is_file()
