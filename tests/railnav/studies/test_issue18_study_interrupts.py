"""Issue 18: a study locks its --out, treats Ctrl-C as an interruption (never a failed
run), saves its finished runs, and survives being killed at random points.

Reference: the tiny study run serially in this process, uninterrupted; a study stopped and
resumed any number of times must give the same table (``runtime_s`` apart) with every run
exactly once in its parts.
"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

import railnav.studies.runs
from railnav.cli import main
from railnav.studies.store import PartStore
from railnav.studies.study import StudyInterrupted, run_study
from tests.conftest import REPO
from tests.railnav.studies.conftest import PART_WAIT_S, TINY
from tests.railnav.studies.conftest import same_table as _same
from trackmodel.files import directory_lock

#: Kills of the study: SIGINT and SIGKILL at seeded random times, on one --out.
KILLS = 2
KILL_SEED = 1818


def _each_once(out, reference) -> None:
    parts = pd.concat([pd.read_parquet(p) for p in PartStore(out).part_paths()])
    assert sorted(parts["run_id"]) == sorted(reference.table["run_id"])


def test_issue18_second_study_on_the_same_out_is_refused(tmp_path, capsys):
    with directory_lock(tmp_path / "study", what="study"):
        code = main(["-q", "study", str(TINY), "--out", str(tmp_path / "study"),
                     "--workers", "1", "--no-plots"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err == (f"error: {tmp_path / 'study'}: another study (pid "
                                 f"{os.getpid()}) is running on it: wait for it or give "
                                 "another folder")
    assert not (tmp_path / "study" / "parts").exists()


def test_issue18_ctrl_c_inside_casadi_is_an_interruption(config, reference, tmp_path,
                                                         monkeypatch):
    """CasADi turns a KeyboardInterrupt raised in its callbacks into a SystemError caused
    by it (the study recorded it as a failed run, and a rerun skipped it)."""
    real = railnav.studies.runs._summary
    calls = []

    def interrupted_at_five(spec):
        calls.append(spec.run_id)
        if len(calls) == 5:
            try:
                raise KeyboardInterrupt
            except KeyboardInterrupt as exc:
                raise SystemError("<casadi> returned a result with an exception set") \
                    from exc
        return real(spec)

    monkeypatch.setattr(railnav.studies.runs, "_summary", interrupted_at_five)
    with pytest.raises(StudyInterrupted, match="4 of 16 runs are saved"):
        run_study(config, tmp_path, workers=1, plots=False)
    saved = PartStore(tmp_path).read()
    assert len(saved) == 4 and (saved["status"] == "ok").all()
    monkeypatch.setattr(railnav.studies.runs, "_summary", real)
    resumed = run_study(config, tmp_path, workers=1, plots=False)
    assert resumed.runs_resumed == 4 and resumed.runs_failed == 0
    _same(resumed.table, reference.table)


def _study(out, *extra) -> subprocess.Popen:
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=str(REPO))
    return subprocess.Popen([sys.executable, "-m", "railnav.cli", "-q", "study", str(TINY),
                             "--out", str(out), "--no-plots", *extra], cwd=REPO, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def test_issue18_study_killed_at_random_points_resumes(config, reference, tmp_path):
    out = tmp_path / "study"
    started = time.perf_counter()
    assert _study(tmp_path / "timing", "--workers", "1").wait(timeout=300) == 0
    life_s = time.perf_counter() - started
    rng = np.random.default_rng(KILL_SEED)
    for sig in [signal.SIGINT] * KILLS + [signal.SIGKILL] * KILLS:
        before = PartStore(out).finished_ids() if out.exists() else set()
        proc = _study(out, "--workers", "1")
        time.sleep(float(rng.uniform(0.2, 0.8)) * life_s)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=300)
        after = PartStore(out).finished_ids() if (out / "parts").exists() else set()
        assert before <= after                        # nothing saved is ever lost
        if sig == signal.SIGINT and "runs are saved" in err:   # (not while importing)
            assert proc.returncode == 130 and "Traceback" not in err
            assert f"interrupted: {len(after)} of 16 runs are saved" in err
    resumed = run_study(config, out, workers=1, plots=False)
    assert resumed.runs_failed == 0
    _same(resumed.table, reference.table)
    _each_once(out, reference)


def test_issue18_ctrl_c_under_dask_no_traceback_no_finished_run_lost(reference, tmp_path):
    out = tmp_path / "study"
    proc = _study(out, "--scheduler", "local", "--workers", "1")
    deadline = time.monotonic() + PART_WAIT_S
    while not list((out / "parts").glob("part-*.parquet")):
        assert proc.poll() is None, "the study ended before it could be interrupted"
        assert time.monotonic() < deadline
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    saved = PartStore(out).finished_ids()
    assert proc.returncode == 130, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    said = int(re.search(r"interrupted: (\d+) of 16 runs are saved", err).group(1))
    assert said == len(saved) >= 3                   # the first part, and what followed
    assert set(saved) <= set(reference.table["run_id"])
