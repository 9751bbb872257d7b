"""Issue 18, the newcomer's list: ``--version``, global flags after the subcommand, what
each command wrote, messages that name their file, one default per option."""
from __future__ import annotations

import json
import shutil
from importlib.metadata import version

import pytest

import railnav
from railnav.cli import build_parser, main
from railnav.defaults import DEFAULT_SYSTEMS
from railnav.errors import ConfigError
from railnav.simulation.scenarios import TRACKS_DIR

PAPER = str(TRACKS_DIR / "paper2017.csv")
CURVY = str(TRACKS_DIR / "curvy.csv")


def test_issue18_version_from_the_package_metadata(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"railnav {version('railnav')}"
    assert railnav.__version__ == version("railnav")


@pytest.mark.parametrize("argv, verbose, quiet, debug", [
    (["run", PAPER, "-v"], 1, False, False),
    (["-v", "run", PAPER], 1, False, False),
    (["run", PAPER, "-q", "--debug"], 0, True, True),
    (["-q", "track", "fit", "s.csv", "--out", "t.csv", "--debug"], 0, True, True),
    (["network", "info", "n", "-vv"], 2, False, False)])
def test_issue18_global_flags_after_the_subcommand(argv, verbose, quiet, debug):
    args = build_parser().parse_args(argv)
    assert (args.verbose, args.quiet, args.debug) == (verbose, quiet, debug)


def test_issue18_debug_after_the_subcommand_shows_the_error(tmp_path):
    argv = ["run", PAPER, "--duration-s", "5", "--window", "10:20", "--out",
            str(tmp_path / "o")]
    assert main(["-q", *argv]) == 2                       # one line
    with pytest.raises(ConfigError, match="window 10-20 s starts after the trip ends"):
        main([*argv, "-q", "--debug"])                    # the traceback, as before it


def _listed(out: str, directory) -> list[str]:
    line = next(ln for ln in out.splitlines() if ln.startswith(f"{directory}/: "))
    return sorted(line.split(": ", 1)[1].split(" (")[0].split(", "))


def test_issue18_run_and_spp_list_what_they_wrote(tmp_path, capsys):
    run = tmp_path / "run"
    assert main(["-q", "run", PAPER, "--duration-s", "10", "--out", str(run)]) == 0
    assert _listed(capsys.readouterr().out, run) == sorted(p.name for p in run.iterdir())
    gnss = TRACKS_DIR.parent / "gnss"
    spp = tmp_path / "spp"
    assert main(["-q", "spp", "--obs", str(gnss / "rover_obs_1240.rnx"), "--nav",
                 str(gnss / "broadcast_nav.rnx"), "--out", str(spp)]) == 0
    assert _listed(capsys.readouterr().out, spp) == ["spp.csv", "spp.png"] == sorted(
        p.name for p in spp.iterdir())


def test_issue18_no_gnss_to_start_from_offers_what_the_cli_has(tmp_path, capsys):
    sim = tmp_path / "sim"
    assert main(["-q", "simulate", PAPER, "--duration-s", "5", "--no-gnss", "--out",
                 str(sim)]) == 0
    code = main(["-q", "run", PAPER, "--imu", str(sim / "imu.csv"), "--out",
                 str(tmp_path / "run")])
    err = capsys.readouterr().err
    assert code == 2 and "--obs/--nav, --fixes" in err and "initial state" not in err


def test_issue18_messages_name_their_file(tmp_path, capsys):
    sim = tmp_path / "sim"
    assert main(["-q", "simulate", PAPER, "--duration-s", "10", "--out", str(sim)]) == 0
    baro = tmp_path / "far_baro.csv"
    baro.write_text("time_s,baro_h_m\n5000,400\n5001,401\n")
    assert main(["-q", "run", PAPER, "--duration-s", "10", "--baro", str(baro), "--out",
                 str(tmp_path / "r1")]) == 2
    assert capsys.readouterr().err.startswith(f"error: {baro}: baro times [5000.0, 5001.0]")
    obs = sim / "gnss_obs.rnx"
    lines = obs.read_text().splitlines(keepends=True)
    empty = tmp_path / "empty.rnx"
    empty.write_text("".join(lines[:next(i for i, ln in enumerate(lines)
                                         if "END OF HEADER" in ln) + 1]))
    assert main(["-q", "spp", "--obs", str(empty), "--nav", str(sim / "gnss_nav.rnx"),
                 "--out", str(tmp_path / "s")]) == 2
    assert f"error: {empty}: no measurements" in capsys.readouterr().err
    assert main(["-q", "run", PAPER, "--imu", str(sim / "imu.csv"), "--obs", str(empty),
                 "--nav", str(sim / "gnss_nav.rnx"), "--out", str(tmp_path / "r2")]) == 2
    assert f"error: {empty}: no GNSS observation" in capsys.readouterr().err


def test_issue18_simulate_and_run_pick_the_same_scenario(tmp_path):
    """One rule: --scenario, else the track's file name if it is a scenario's, else curvy
    (simulate defaulted to paper2017 and simulated its profile on curvy.csv)."""
    mine = tmp_path / "mine.csv"
    shutil.copy(CURVY, mine)
    for track, expected in ((CURVY, "curvy"), (PAPER, "paper2017"), (str(mine), "curvy")):
        out = tmp_path / f"sim-{expected}-{len(track)}"
        assert main(["-q", "simulate", track, "--duration-s", "2", "--no-gnss", "--out",
                     str(out)]) == 0
        assert json.loads((out / "scenario.json").read_text())["scenario"]["name"] == expected
        run = tmp_path / f"run-{expected}-{len(track)}"
        assert main(["-q", "run", track, "--duration-s", "2", "--no-plots", "--out",
                     str(run)]) == 0
        assert json.loads((run / "summary.json").read_text())["scenario"] == expected


def test_issue18_one_default_per_option():
    parser = build_parser()
    for argv, command in ((["simulate", PAPER], "simulate"), (["run", PAPER], "run"),
                          (["spp", "--obs", "o", "--nav", "n"], "spp"),
                          (["reproduce", "paper2017"], "reproduce"),
                          (["study", "s.toml"], "study"),
                          (["network", "run", "n", "--start", "E1:0"], "network-run")):
        args = parser.parse_args(argv)
        assert args.out == f"railnav-{command}", argv
    for argv in (["simulate", PAPER], ["spp", "--obs", "o", "--nav", "n"]):
        assert parser.parse_args(argv).systems == DEFAULT_SYSTEMS
    # run: the simulated systems for railnav simulate's files, else the same default
    assert parser.parse_args(["run", PAPER]).systems is None


@pytest.mark.parametrize("argv", [
    ["run", PAPER, "-v", "--no-plots", "--seed", "3"],
    ["-q", "--debug", "run", PAPER, CURVY, "--duration-s", "20"],
    ["-q", "track", "fit", "s.csv", "--out", "t.csv", "--debug"],
    ["network", "info", "n", "-vv"],
    ["-v", "simulate", PAPER, "--no-gnss"],
    ["reproduce", "paper2017", "--runs", "2"]])
def test_the_parser_of_the_command_named_parses_as_the_full_parser(argv):
    """Reference: the parser with every command (`build_parser()`); the one built for
    `argv` registers the command it names only, and must read `argv` the same way."""
    assert vars(build_parser(argv).parse_args(argv)) == vars(build_parser().parse_args(argv))
    only = build_parser(argv)._subparsers._group_actions[0].choices
    assert list(only) == [next(a for a in argv if not a.startswith("-"))]
