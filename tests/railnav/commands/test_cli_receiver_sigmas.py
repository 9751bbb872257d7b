"""``railnav run --sigma-pr-m --sigma-rr-mps``: the receiver's GNSS noise for a file run,
and the hint when it was not given and the rows say the default σ are too small (the
adaptive noise scale's line, or the share of rejected rows).

The trip: a 150-s ``curvy`` simulation (the 2017 paper's receiver, noisier than the real
receiver the defaults describe) copied without ``scenario.json``. Reference: the run's own
innovations.csv (each row's ``accepted``), and the same files with ``scenario.json``.
"""
from __future__ import annotations

import json
import math
import shutil

import pandas as pd
import pytest

from railnav.cli import main
from railnav.commands.run_report import (HINT_REJECTED_SHARE, REPORT_SCALE,
                                        noise_scale_lines, receiver_hint_lines)
from railnav.simulation.scenarios import TRACKS_DIR

CURVY = str(TRACKS_DIR / "curvy.csv")
FILES = ("imu.csv", "gnss_obs.rnx", "gnss_nav.rnx", "truth.csv")


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sim")
    assert main(["-q", "simulate", CURVY, "--duration-s", "150", "--seed", "0",
                 "--out", str(folder)]) == 0
    plain = tmp_path_factory.mktemp("plain")
    for name in FILES:
        shutil.copy(folder / name, plain / name)
    return folder, plain


def _run(folder, out, capsys, *extra) -> str:
    capsys.readouterr()
    assert main(["run", CURVY, "--imu", str(folder / "imu.csv"), "--obs",
                 str(folder / "gnss_obs.rnx"), "--nav", str(folder / "gnss_nav.rnx"),
                 "--truth", str(folder / "truth.csv"), *extra, "--no-plots",
                 "--out", str(out)]) == 0
    return capsys.readouterr().out


def _hint(text: str) -> list[str]:
    return [line for line in text.splitlines() if "--sigma-pr-m" in line]


def test_plain_files_untold_get_the_hint_with_the_noise_scale(sim, tmp_path, capsys):
    """Told nothing, the adaptive noise scale (`railnav.filters.noise_scale`) rises for
    both row kinds: one hint, with the largest factors of ``innovations.csv``'s
    ``noise_scale``."""
    text = _run(sim[1], tmp_path / "a", capsys, "--imu-grade", "tactical")
    inn = pd.read_csv(tmp_path / "a" / "innovations.csv")
    top = inn.groupby("kind")["noise_scale"].max()
    assert top["pseudorange"] > REPORT_SCALE and top["range_rate"] > REPORT_SCALE
    assert len(_hint(text)) == 1
    assert (f"pseudorange up to {top['pseudorange']:.1f}×, range rate up to "
            f"{top['range_rate']:.1f}×") in _hint(text)[0]


def test_the_rejected_rows_hint_when_the_scale_did_not_rise():
    """Without a scale above `REPORT_SCALE` (off, or not significant), the hint counts the
    rejected rows; with one, the scale's line says it and this hint is not repeated."""
    stats = {"gnss_rows": 200, "gnss_rows_rejected": 60}
    assert "60 of 200 GNSS rows (30 %)" in receiver_hint_lines({"statistics": stats})[0]
    low = {"range_rate": {"final": 1.0, "max": REPORT_SCALE}}
    assert receiver_hint_lines({"statistics": {**stats, "noise_scale": low}})
    assert not noise_scale_lines({"statistics": {**stats, "noise_scale": low}})
    high = {"range_rate": {"final": 1.0, "max": 2.04}}
    assert not receiver_hint_lines({"statistics": {**stats, "noise_scale": high}})
    line, = noise_scale_lines({"statistics": {**stats, "noise_scale": high}})
    assert "range rate up to 2.0×" in line and "pseudorange" not in line


def test_plain_files_told_the_sigmas_run_as_with_the_scenario(sim, tmp_path, capsys):
    scenario = json.loads((sim[0] / "scenario.json").read_text())["scenario"]
    text = _run(sim[1], tmp_path / "b", capsys, "--imu-grade", "tactical", "--sigma-pr-m",
                repr(scenario["sigma_pseudorange_m"]), "--sigma-rr-mps",
                repr(scenario["sigma_range_rate_mps"]))
    assert scenario["sigma_pseudorange_m"] == pytest.approx(math.sqrt(15.0))
    assert not _hint(text)
    told = json.loads((tmp_path / "b" / "summary.json").read_text())["statistics"]
    assert told["monitor"]["recoveries"] == 0
    # the scenario's files (σ from scenario.json) are below the hint's share too
    assert not _hint(_run(sim[0], tmp_path / "c", capsys))
    inn = pd.read_csv(tmp_path / "c" / "innovations.csv")
    assert (~inn["accepted"]).sum() <= HINT_REJECTED_SHARE * len(inn)


@pytest.mark.parametrize("extra, message", [
    (["--fixes", "f.nmea", "--sigma-pr-m", "3"], "--sigma-pr-m: only with --obs"),
    (["--imu", "i.csv", "--sigma-rr-mps", "0.5"], "--sigma-rr-mps: only with --obs"),
])
def test_receiver_sigmas_without_observations_are_one_line_exit_2(tmp_path, capsys, extra,
                                                                  message):
    code = main(["-q", "run", CURVY, *extra, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("error: ") and message in err and "\n" not in err, err


def test_receiver_sigmas_are_not_taken_by_a_network_run(tmp_path, capsys):
    code = main(["-q", "run", "--network", str(tmp_path / "net"), "--obs", "o", "--nav", "n",
                 "--sigma-pr-m", "3", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "--sigma-pr-m: not with --network" in err, err


def test_no_noise_scale_keeps_the_given_sigmas(sim, tmp_path, capsys):
    """``--no-noise-scale``: told nothing, the rows keep the real receiver's σ (their
    ``noise_scale`` all 1, where the scale on rises: the first test), so many are rejected
    and the report falls back on the rejected-rows hint; told the right σ, the scale never rose, so the estimates are those
    of the run with it on, to the bit."""
    text = _run(sim[1], tmp_path / "off", capsys, "--imu-grade", "tactical",
                "--no-noise-scale")
    inn = pd.read_csv(tmp_path / "off" / "innovations.csv")
    stats = json.loads((tmp_path / "off" / "summary.json").read_text())["statistics"]
    assert (inn["noise_scale"] == 1.0).all()
    assert stats["noise_scale"]["pseudorange"]["max"] == 1.0
    assert stats["gnss_rows_rejected"] > HINT_REJECTED_SHARE * stats["gnss_rows"]
    assert len(_hint(text)) == 1 and "GNSS rows" in _hint(text)[0]
    scenario = json.loads((sim[0] / "scenario.json").read_text())["scenario"]
    told = ("--imu-grade", "tactical", "--sigma-pr-m", repr(scenario["sigma_pseudorange_m"]),
            "--sigma-rr-mps", repr(scenario["sigma_range_rate_mps"]))
    _run(sim[1], tmp_path / "on", capsys, *told)
    _run(sim[1], tmp_path / "told_off", capsys, *told, "--no-noise-scale")
    on = pd.read_csv(tmp_path / "on" / "innovations.csv")
    assert (on["noise_scale"].dropna() == 1.0).all()
    assert ((tmp_path / "on" / "estimates.csv").read_bytes()
            == (tmp_path / "told_off" / "estimates.csv").read_bytes())


@pytest.mark.parametrize("extra, message", [
    (["--filter", "unconstrained", "--no-noise-scale"],
     "--no-noise-scale: the unconstrained filter has no noise scale"),
    (["--fixes", "f.nmea", "--no-noise-scale"], "--no-noise-scale: scales GNSS observation"),
    ([CURVY, "--no-noise-scale"], "--no-noise-scale: one track only"),
])
def test_no_noise_scale_where_there_is_none_is_one_line_exit_2(tmp_path, capsys, extra,
                                                               message):
    code = main(["-q", "run", CURVY, *extra, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("error: ") and message in err and "\n" not in err, err
