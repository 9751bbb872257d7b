"""Issue 18: output directories are written whole or not at all.

An existing non-empty ``--out`` is refused unless ``--overwrite`` (then replaced whole); an
unwritable destination is found before any computation and named as the user gave it; a
run killed at a random point (SIGINT or SIGKILL) leaves a complete ``--out`` or none.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import railnav.jobs.run
from railnav.cli import main
from railnav.simulation.scenarios import TRACKS_DIR

PAPER = str(TRACKS_DIR / "paper2017.csv")
REPO = Path(__file__).resolve().parents[3]
RUN = ["run", PAPER, "--duration-s", "10", "--no-plots"]


def _hidden(parent: Path) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if p.name.startswith("."))


def test_issue18_existing_out_is_refused_then_replaced_whole(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["-q", "run", PAPER, "--duration-s", "10", "--out", str(out)]) == 0
    with_plots = sorted(p.name for p in out.iterdir())
    assert "track.png" in with_plots
    before = (out / "summary.json").read_bytes()
    capsys.readouterr()
    assert main(["-q", *RUN, "--seed", "4", "--out", str(out)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"error: {out}: exists and is not empty: nothing was written (--overwrite replaces "
        "it whole)")
    assert (out / "summary.json").read_bytes() == before
    (out / "notes.txt").write_text("mine")
    assert main(["-q", *RUN, "--seed", "4", "--out", str(out), "--overwrite"]) == 0
    after = sorted(p.name for p in out.iterdir())
    # no stale file: the plots and notes.txt of before are gone, the new run's files remain
    assert after == sorted(set(with_plots) - {"track.png", "errors.png"})
    assert json.loads((out / "summary.json").read_text())["seed"] == 4
    assert _hidden(tmp_path) == []


def _no_computation(*args, **kwargs):
    raise AssertionError("computed although the destination cannot be written")


@pytest.mark.parametrize("command", [
    ["run", PAPER, "--duration-s", "10"],
    ["simulate", PAPER, "--duration-s", "10"],
    ["spp", "--obs", str(TRACKS_DIR.parent / "gnss" / "rover_obs_1240.rnx"), "--nav",
     str(TRACKS_DIR.parent / "gnss" / "broadcast_nav.rnx")]])
def test_issue18_unwritable_out_is_found_before_any_work(tmp_path, capsys, monkeypatch,
                                                         command):
    for name in ("run_simulated", "run_files"):
        monkeypatch.setattr(railnav.jobs.run, name, _no_computation)
    monkeypatch.setattr("railnav.simulation.trip.simulate_trip", _no_computation)
    # railnav spp's computation, reading included (patched where the command looks it up:
    # patching gnss_obs.spp.solve_spp would bind the stub into railnav.jobs.spp for good
    # when this test is the first to import it)
    monkeypatch.setattr("railnav.jobs.spp.spp_files", _no_computation)
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    out = blocker / "out"              # a folder under a file: no one can create it
    assert main(["-q", *command, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {out}: cannot write here: ") and ".tmp-" not in err


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0,
                    reason="permissions do not stop root")
def test_issue18_read_only_parent_is_found_before_any_work(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(railnav.jobs.run, "run_simulated", _no_computation)
    parent = tmp_path / "ro"
    parent.mkdir()
    parent.chmod(0o555)
    assert main(["-q", *RUN, "--out", str(parent / "out")]) == 2
    assert capsys.readouterr().err.startswith(f"error: {parent / 'out'}: cannot write here")


def test_issue18_overwrite_keeps_the_inputs_it_reads(tmp_path, capsys):
    sim = tmp_path / "sim"
    assert main(["-q", "simulate", PAPER, "--duration-s", "10", "--out", str(sim)]) == 0
    code = main(["-q", "run", PAPER, "--imu", str(sim / "imu.csv"), "--obs",
                 str(sim / "gnss_obs.rnx"), "--nav", str(sim / "gnss_nav.rnx"), "--no-plots",
                 "--out", str(sim), "--overwrite"])
    assert code == 2 and "holds an input" in capsys.readouterr().err
    assert (sim / "imu.csv").is_file()


def test_issue18_failed_run_leaves_nothing(tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(railnav.jobs.run, "write_run", broken)
    out = tmp_path / "run"
    assert main(["-q", *RUN, "--out", str(out)]) == 130
    assert not out.exists() and _hidden(tmp_path) == []


def test_issue18_reproduce_refuses_an_existing_result(tmp_path, capsys):
    (tmp_path / "paper2017.json").write_text("{}")
    assert main(["-q", "reproduce", "paper2017", "--runs", "1", "--out", str(tmp_path)]) == 2
    assert "paper2017.json: exists" in capsys.readouterr().err
    assert (tmp_path / "paper2017.json").read_text() == "{}"


#: Kills of a run: SIGINT and SIGKILL at seeded random times over its whole life.
KILLS = 3
KILL_SEED = 18


def _spawn(out: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.Popen([sys.executable, "-m", "railnav.cli", "-q", "run", PAPER,
                             "--duration-s", "30", "--out", str(out)], cwd=REPO, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def test_issue18_killed_run_leaves_a_complete_out_or_none(tmp_path):
    reference = tmp_path / "reference"
    started = time.perf_counter()
    assert _spawn(reference).wait(timeout=300) == 0
    life_s = time.perf_counter() - started
    expected = sorted(p.name for p in reference.iterdir())
    rng = np.random.default_rng(KILL_SEED)
    outcomes = []
    for k, sig in enumerate([signal.SIGINT] * KILLS + [signal.SIGKILL] * KILLS):
        out = tmp_path / f"killed{k}"
        proc = _spawn(out)
        time.sleep(float(rng.uniform(0.1, 1.1)) * life_s)   # some land after the end
        proc.send_signal(sig)
        proc.wait(timeout=300)
        if out.exists():
            assert sorted(p.name for p in out.iterdir()) == expected, (sig, k)
            assert json.loads((out / "summary.json").read_text())["steps"] > 0
        outcomes.append(out.exists())
        if sig == signal.SIGINT:        # an interrupted run cleans up after itself
            assert not [n for n in _hidden(tmp_path) if n.startswith(f".killed{k}")]
    # what SIGKILL leaves (a hidden sibling) is removed by the next run on that --out
    out = tmp_path / f"killed{2 * KILLS - 1}"
    assert _spawn(out).wait(timeout=300) in (0, 2)
    assert not [n for n in _hidden(tmp_path) if n.startswith(f".{out.name}.")]
