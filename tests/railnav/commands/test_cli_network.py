"""``railnav network build|info|routes|run`` (issue 13): files written, lines printed,
one-line errors. References: the network file's own topology (the switch excerpt) and
the route probabilities of `railnav.jobs.network` on the same simulated trip."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from railnav.cli import main
from trackmodel.network_io import read_network

NETWORKS = Path(__file__).resolve().parents[3] / "data" / "networks"
BRUSSELS = str(NETWORKS / "brussels_airport")


def test_build_and_info_from_geojson(tmp_path, capsys):
    out = tmp_path / "net"
    assert main(["-q", "network", "build", str(NETWORKS / "brussels_switch.geojson"),
                 "--out", str(out)]) == 0
    assert "3 netelements" in capsys.readouterr().out
    net = read_network(out)
    assert net.successors("88_L_9755", -1) == [("88_L_11801", -1), ("88_L_2014", -1)]
    assert main(["network", "info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "3 joints, 2 navigable" in text and "88_L_9755" in text


def test_routes_are_listed(capsys):
    assert main(["network", "routes", BRUSSELS, "--start", "88_L_111:1000:-",
                 "--horizon-m", "2500"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 3 and all("-88_L_111>" in line for line in lines)


def test_run_identifies_the_route(tmp_path, capsys):
    """A trip simulated along route 0 (88_L_111 backwards, then the switch's way onto
    88_L_154): the network navigator, told the start element only, ends on 88_L_154 with
    probability > 0.99 and writes the network run's files."""
    out = tmp_path / "run"
    assert main(["-q", "network", "run", BRUSSELS, "--start", "88_L_111:1000:-",
                 "--horizon-m", "2500", "--true-route", "0", "--duration-s", "75",
                 "--no-plots", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    route = summary["route"]
    assert route["true_route"] == ["88_L_111", "88_L_154", "88_L_7815"]
    assert route["netelements"] == ["88_L_111", "88_L_154"]
    assert route["final_probability"] > 0.99
    assert route["truth"]["navigable"] and route["truth"]["passes_truth"]
    for name in ("estimates.csv", "hypotheses.csv", "route.csv", "innovations.csv"):
        assert (out / name).is_file()


@pytest.mark.parametrize("argv, message", [
    (["network", "routes", BRUSSELS, "--start", "nope:1"], "--start 'nope': no such netelement"),
    (["network", "info", "missing-folder"], "missing-folder"),
    (["network", "build", "missing.geojson", "--out", "x"], "missing.geojson"),
    (["network", "run", BRUSSELS, "--start", "88_L_111:10", "--imu", "i.csv",
      "--duration-s", "5"], "--duration-s"),
])
def test_bad_input_is_one_line_exit_2(tmp_path, capsys, argv, message):
    assert main(["-q", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and message in err and "\n" not in err


FIXES_28554 = str(NETWORKS.parent / "fixes" / "brussels" / "log_28554_L36-A_to_L36C-A.csv")


@pytest.mark.parametrize("argv, flag", [
    (["network", "routes", BRUSSELS, "--start", "88_L_999:10:-"], "--start"),
    (["network", "run", BRUSSELS, "--start", "88_L_999:10", "--out", "OUT"], "--start"),
    (["run", "--network", BRUSSELS, "--fixes", FIXES_28554, "--start", "88_L_999",
      "--out", "OUT"], "--start"),
    (["simulate", "--network", BRUSSELS, "--route", "88_L_111,88_L_999", "--out", "OUT"],
     "--route"),
    (["network", "route", BRUSSELS, "--elements", "88_L_111,88_L_999"], "--elements"),
    (["network", "route", BRUSSELS, "--from", "88_L_111:10", "--to", "88_L_999:5"], "--to"),
])
def test_a_netelement_not_in_the_network_names_the_network(tmp_path, capsys, argv, flag):
    """A netelement the network does not have (88_L_999: the Brussels folder's 74 are
    listed in its elements.csv) is a one-line error that names the network, the option
    and the name, exit 2, nothing written; it said 'no netelement ... in the network'
    without saying which."""
    out = tmp_path / "out"
    assert main(["-q", *[str(out) if a == "OUT" else a for a in argv]]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: {BRUSSELS}: {flag} ")
    assert "'88_L_999'" in err and "netelement" in err
    assert not out.exists()
